"""Saying alarms aloud: a siren tone, then the alarm's sentence from a real speech synthesizer (espeak-ng).

What ROS's sound_play does for a robot, for the alarm module's announcements. Each announcement becomes one WAV
file (siren, a short pause, the sentence), written to ``output_dir``; when the machine has a sound card it is
also played through ALSA (``aplay``), one at a time. Announcements that arrive while one plays wait, at most
one per alarm name: repeated triggers of one alarm never stack up a queue of sounds.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import wave
from pathlib import Path

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from std_msgs.msg import String

from subsumption import Input, Module, Output, Param

SYNTHESIZER = "espeak-ng"
PLAYER = "aplay"


class SoundError(RuntimeError):
    """The synthesizer or the player is missing or failed; the message names the program."""


def speech(text: str, voice: str = "en", words_per_minute: int = 160) -> tuple[np.ndarray, int]:
    """(int16 samples, sample rate) of `text` spoken by espeak-ng."""
    if shutil.which(SYNTHESIZER) is None:
        raise SoundError(f"{SYNTHESIZER} not found on PATH: the alarm cannot speak (apt-get install espeak-ng)")
    done = subprocess.run([SYNTHESIZER, "-v", voice, "-s", str(int(words_per_minute)), "--stdout", text],
                          capture_output=True, timeout=30)
    if done.returncode != 0 or not done.stdout:
        raise SoundError(f"{SYNTHESIZER} -v {voice} failed (status {done.returncode}): "
                         f"{done.stderr.decode(errors='replace').strip()}")
    return read_wav_bytes(done.stdout)


def read_wav_bytes(data: bytes) -> tuple[np.ndarray, int]:
    """Samples and rate of a mono 16-bit WAV held in memory. espeak-ng writes its stream's length fields as
    'unknown' (0xFFFFFFFF), so the data chunk is taken to run to the end of the bytes."""
    start = data.find(b"data")
    if data[:4] != b"RIFF" or start < 0:
        raise SoundError(f"{SYNTHESIZER} did not produce a WAV stream")
    rate = int.from_bytes(data[24:28], "little")
    channels = int.from_bytes(data[22:24], "little")
    samples = np.frombuffer(data[start + 8:len(data) - (len(data) - start - 8) % 2], dtype="<i2")
    return (samples.reshape(-1, channels)[:, 0] if channels > 1 else samples).copy(), rate


def siren(rate: int, seconds: float = 1.0, low: float = 650.0, high: float = 1050.0) -> np.ndarray:
    """A two-tone wail (low and high alternating four times a second) as int16 samples."""
    t = np.arange(int(rate * seconds)) / rate
    frequency = np.where((t * 4).astype(int) % 2 == 0, low, high)
    phase = 2 * np.pi * np.cumsum(frequency) / rate
    envelope = np.minimum(1.0, np.minimum(t, seconds - t) / 0.02)  # no clicks at the ends
    return (0.6 * 32767 * envelope * np.sin(phase)).astype(np.int16)


def write_wav(path: Path, samples: np.ndarray, rate: int) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with wave.open(str(path), "wb") as out:
        out.setnchannels(1)
        out.setsampwidth(2)
        out.setframerate(rate)
        out.writeframes(samples.astype("<i2").tobytes())
    return path


def alarm_sound(text: str, voice: str = "en", words_per_minute: int = 160, siren_s: float = 1.0) -> tuple[np.ndarray, int]:
    """Siren, 0.2 s of silence, then the sentence."""
    spoken, rate = speech(text, voice, words_per_minute)
    return np.concatenate([siren(rate, siren_s), np.zeros(int(0.2 * rate), np.int16), spoken]), rate


def sound_card_present() -> bool:
    """Whether ALSA sees a playback device (``aplay -l`` lists a card)."""
    if shutil.which(PLAYER) is None:
        return False
    listed = subprocess.run([PLAYER, "-l"], capture_output=True, text=True, timeout=10)
    return listed.returncode == 0 and "card " in listed.stdout


def default_output_dir() -> Path:
    return Path(os.environ.get("ROS_HOME", Path.home() / ".ros")) / "sound"


class SoundPlay(Module):
    """Speaks each announced alarm (siren and sentence) into a WAV file, and plays it when there is a sound card;
    never more than one waiting sound per alarm."""

    announce = Input(DiagnosticStatus, "an alarm to say: name is what, message is the sentence")
    played = Output(String, "'NAME: SENTENCE -> FILE.wav' for each sound written (and played, if a card is there)")
    voice = Param("en", "espeak-ng voice the alarms are spoken in")
    words_per_minute = Param(160, "speech rate, words per minute")
    siren_s = Param(1.0, "s of siren before the sentence")
    output_dir = Param("", "where WAV files go (default: $ROS_HOME/sound)")
    playback = Param("auto", "auto (play when ALSA has a card), always, or never")

    def setup(self) -> None:
        if self.playback not in ("auto", "always", "never"):
            raise ValueError(f"{self.name}: parameter ~playback must be auto, always or never, got {self.playback!r}")
        if shutil.which(SYNTHESIZER) is None:
            raise SoundError(f"{self.name}: {SYNTHESIZER} not found on PATH (apt-get install espeak-ng)")
        self.directory = Path(self.output_dir) if self.output_dir else default_output_dir()
        self.play_aloud = self.playback == "always" or (self.playback == "auto" and sound_card_present())
        self.files: list[Path] = []
        self._pending: dict[str, DiagnosticStatus] = {}  # alarm name -> the latest announcement waiting
        self._playing: subprocess.Popen | None = None
        if self.play_aloud:
            self.every(0.2, self._next)
        self.log(f"alarm sounds to {self.directory}" + (" and the sound card" if self.play_aloud else
                                                          " (no sound card: files only)"))

    def on_announce(self, status: DiagnosticStatus) -> None:
        if not self.play_aloud:
            self._say(status)
            return
        self._pending[status.name] = status  # a newer announcement of the same alarm replaces the waiting one
        self._next()

    def _next(self) -> None:
        if self._playing is not None and self._playing.poll() is None:
            return
        self._playing = None
        if self._pending:
            name = next(iter(self._pending))
            path = self._say(self._pending.pop(name))
            if path is not None:
                self._playing = subprocess.Popen([PLAYER, "-q", str(path)], stdout=subprocess.DEVNULL,
                                                 stderr=subprocess.DEVNULL)

    def _say(self, status: DiagnosticStatus) -> Path | None:
        text = status.message or status.name
        try:
            samples, rate = alarm_sound(text, self.voice, self.words_per_minute, self.siren_s)
        except (SoundError, subprocess.TimeoutExpired) as error:
            self.log(f"cannot say alarm {status.name!r}: {error}", "error")
            return None
        safe = re.sub(r"[^A-Za-z0-9_-]+", "_", status.name)[:40] or "alarm"
        path = write_wav(self.directory / f"alarm_{len(self.files):03d}_{safe}_{self.now():.1f}s.wav", samples, rate)
        self.files.append(path)
        self.played.publish(String(f"{status.name}: {text} -> {path}"))
        return path
