"""The patrol robot's alarm and sound modules: raise, refresh, clear, no stacking; real speech in real WAV files."""
from __future__ import annotations

import subprocess
import wave

import pytest
from diagnostic_msgs.msg import DiagnosticStatus

from robots.patrol.alarm import Alarm, alarm_status
from robots.patrol.sound import SoundPlay, siren
from subsumption.testing import Harness


def values(status: DiagnosticStatus) -> dict[str, str]:
    return {kv.key: kv.value for kv in status.values}


def test_an_alarm_triggered_again_and_again_is_raised_and_announced_once():
    h = Harness(Alarm, params={"repeat": 10.0, "hold": 5.0})
    for _ in range(30):  # a detector firing at 10 Hz for 3 s
        h.feed("trigger", alarm_status("intruder", "Intruder at x 3.0, y 1.0", 3.0, 1.0))
        h.run_for(0.1)
    announced = h.sent("announce")
    assert [a.name for a in announced] == ["intruder"]
    assert values(announced[0])["x"] == "3.00" and values(announced[0])["frame"] == "map"
    assert float(values(announced[0])["raised_at"]) == pytest.approx(0.0)
    raised = h.sent("alarms")[-1].status
    assert [s.name for s in raised] == ["intruder"] and raised[0].level == DiagnosticStatus.WARN
    assert h.module.count == 1


def test_hold_clears_an_alarm_nobody_triggers_and_a_later_trigger_raises_it_again():
    h = Harness(Alarm, params={"hold": 2.0, "repeat": 100.0})
    h.feed("trigger", alarm_status("bumper", "Bumped"))
    h.run_for(3.0)
    assert h.sent("alarms")[-1].status == []
    h.feed("trigger", alarm_status("bumper", "Bumped again"))
    assert [a.message for a in h.sent("announce")] == ["Bumped", "Bumped again"]
    assert h.module.count == 2


def test_level_ok_clears_at_once_and_other_alarms_stay():
    h = Harness(Alarm, params={"hold": 0.0})
    h.feed("trigger", alarm_status("intruder", "Intruder"))
    h.feed("trigger", alarm_status("navigation", "Goal 2 failed"))
    assert sorted(s.name for s in h.sent("alarms")[-1].status) == ["intruder", "navigation"]
    h.feed("trigger", alarm_status("intruder", "gone", level=DiagnosticStatus.OK))
    assert [s.name for s in h.sent("alarms")[-1].status] == ["navigation"]


def test_repeat_announces_a_still_raised_alarm_again():
    h = Harness(Alarm, params={"hold": 0.0, "repeat": 2.0})
    for _ in range(25):
        h.feed("trigger", alarm_status("intruder", "Intruder"))
        h.run_for(0.2)
    assert len(h.sent("announce")) == 3  # at 0, 2 and 4 s


def wav_facts(path) -> tuple[float, float]:
    """(seconds, peak amplitude 0..1) as sox reports them: a real tool, not our own reader."""
    length = float(subprocess.run(["sox", "--i", "-D", str(path)], capture_output=True, text=True,
                                  check=True).stdout)
    stat = subprocess.run(["sox", str(path), "-n", "stat"], capture_output=True, text=True, check=True).stderr
    peak = float(next(line for line in stat.splitlines() if line.startswith("Maximum amplitude")).split(":")[1])
    return length, peak


def test_each_announcement_becomes_a_wav_with_siren_and_speech_of_the_length_the_text_needs(tmp_path):
    h = Harness(SoundPlay, params={"output_dir": str(tmp_path), "playback": "never", "siren_s": 1.0})
    short = "Alarm"
    long = "Intruder detected in the ping pong room, near the north east corner of the table"
    h.feed("announce", alarm_status("a", short))
    h.feed("announce", alarm_status("b", long))
    files = sorted(tmp_path.glob("*.wav"))
    assert [f.name.split("_")[2] for f in files] == ["a", "b"]
    (short_s, short_peak), (long_s, long_peak) = wav_facts(files[0]), wav_facts(files[1])
    assert short_peak > 0.3 and long_peak > 0.3  # not silent
    assert 1.2 + 0.3 < short_s < 1.2 + 2.0  # siren and pause, then one word
    words = len(long.split())
    assert long_s > 1.2 + words * 60 / 160 * 0.6  # at least 60% of the time 160 words a minute needs
    with wave.open(str(files[1])) as w:  # the speech part is not silent either: look past the siren
        w.setpos(int(1.5 * w.getframerate()))
        tail = w.readframes(w.getframerate())
    assert max(abs(int.from_bytes(tail[i:i + 2], "little", signed=True)) for i in range(0, len(tail), 2)) > 3000
    assert h.sent("played")[-1].data.endswith(str(files[1]))


def test_repeated_announcements_of_one_alarm_wait_as_one_when_playing_aloud(tmp_path, monkeypatch):
    """With a (pretend-busy) player, ten announcements of one alarm leave one waiting sound, not ten."""
    h = Harness(SoundPlay, params={"output_dir": str(tmp_path), "playback": "always", "siren_s": 0.2})
    busy = subprocess.Popen(["sleep", "30"])
    try:
        h.module._playing = busy  # the sound card is busy with an earlier alarm
        for i in range(10):
            h.feed("announce", alarm_status("intruder", f"Intruder {i}"))
        h.feed("announce", alarm_status("bumper", "Bumped"))
        assert list(h.module._pending) == ["intruder", "bumper"]
        assert h.module._pending["intruder"].message == "Intruder 9"  # the latest one waits
        assert list(tmp_path.glob("*.wav")) == []
    finally:
        busy.kill()
        busy.wait()


def test_bad_playback_parameter_is_named():
    with pytest.raises(ValueError, match="~playback must be auto, always or never"):
        Harness(SoundPlay, params={"playback": "loud"})


def test_siren_alternates_two_tones():
    import numpy as np

    tone = siren(8000, 1.0)
    spectrum_first = np.abs(np.fft.rfft(tone[:2000]))  # first quarter second: the low tone
    spectrum_second = np.abs(np.fft.rfft(tone[2000:4000]))
    assert np.argmax(spectrum_first) * 4 == pytest.approx(650, abs=8)
    assert np.argmax(spectrum_second) * 4 == pytest.approx(1050, abs=8)
