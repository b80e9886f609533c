// The operator terminal's page: camera with the tracked box, map, network with lit arbiters, alarms, and the
// operator's actions (box + Enter, drive keys, stop, release). Everything goes through the rosbridge
// WebSocket of the page's own server; /config.json says which topics are which.
import { Bridge } from "./rosbridge.js";

const $ = (id) => document.getElementById(id);
const stats = { frames: 0, drawn: 0, latencies: [], lastStamp: 0, fps: 0, keyEvents: [] };
window.terminalStats = stats;   // read by tests and bench/terminal

const DRIVE_KEYS = {
  ArrowUp: [1, 0], KeyW: [1, 0], ArrowDown: [-1, 0], KeyS: [-1, 0],
  ArrowLeft: [0, 1], KeyA: [0, 1], ArrowRight: [0, -1], KeyD: [0, -1],
};

let config = null;
let bridge = null;
const state = {
  frame: null, box: null, manualBox: null, drag: null, pendingBox: null,
  map: null, mapImage: null, robot: null, goals: [], plan: [], target: null,
  alarms: new Map(), arbiters: new Map(), operator: false,
};

function now() { return performance.timeOrigin + performance.now(); }   // ms since the epoch
function stampSeconds(header) { return header && header.stamp ? header.stamp.secs + header.stamp.nsecs * 1e-9 : 0; }

// ---------------------------------------------------------------------------------------------- notices
let noticeTimer = null;
function notice(text, kind = "error") {
  const element = $("notice");
  element.textContent = text;
  element.className = `notice ${kind === "error" ? "" : "info"}`;
  clearTimeout(noticeTimer);
  noticeTimer = setTimeout(() => element.classList.add("hidden"), 6000);
}

function onStatus(message) {
  if (message.id === "terminal/control") {
    state.operator = message.msg === "you hold control";
    const badge = $("control");
    badge.textContent = state.operator ? "operator (you)" : "viewer";
    badge.className = `badge ${state.operator ? "operator" : ""}`;
    if (message.level === "warning") notice(message.msg);
    return;
  }
  if (message.level === "error" || message.level === "warning") notice(message.msg);
}

// ---------------------------------------------------------------------------------------------- camera
const camera = $("camera");
const cameraContext = camera.getContext("2d");
let decoding = false;
let pendingFrame = null;

function base64Bytes(text) {
  const binary = atob(text);
  const bytes = new Uint8Array(binary.length);
  for (let i = 0; i < binary.length; i++) bytes[i] = binary.charCodeAt(i);
  return bytes;
}

async function onFrame(msg) {
  stats.frames++;
  if (decoding) { pendingFrame = msg; return; }   // keep only the newest frame while one decodes
  decoding = true;
  try {
    let next = msg;
    while (next) {
      pendingFrame = null;
      const bitmap = await createImageBitmap(new Blob([base64Bytes(next.data)], { type: "image/jpeg" }));
      if (state.frame) state.frame.close();
      state.frame = bitmap;
      if (camera.width !== bitmap.width || camera.height !== bitmap.height) {
        camera.width = bitmap.width;
        camera.height = bitmap.height;
      }
      drawCamera();
      const stamp = stampSeconds(next.header);
      stats.drawn++;
      stats.lastStamp = stamp;
      // a latency only for stamps on the wall clock: a simulation stamps its frames with its own time
      if (stamp > 0 && Math.abs(now() / 1000 - stamp) < 60) {
        stats.latencies.push(now() / 1000 - stamp);
        if (stats.latencies.length > 1000) stats.latencies.shift();
      }
      next = pendingFrame;
    }
  } catch (error) {
    notice(`camera frame could not be decoded: ${error}`);
  } finally {
    decoding = false;
  }
}

function strokeBox(box, colour, dashed, label) {
  if (!box || !(box.width > 0 && box.height > 0)) return;
  cameraContext.save();
  cameraContext.lineWidth = Math.max(2, camera.width / 240);
  cameraContext.strokeStyle = colour;
  if (dashed) cameraContext.setLineDash([8, 5]);
  cameraContext.strokeRect(box.x_offset, box.y_offset, box.width, box.height);
  if (label) {
    cameraContext.font = `${Math.max(12, camera.width / 40)}px sans-serif`;
    cameraContext.fillStyle = colour;
    cameraContext.fillText(label, box.x_offset + 3, Math.max(14, box.y_offset - 5));
  }
  cameraContext.restore();
}

function drawCamera() {
  if (state.frame) cameraContext.drawImage(state.frame, 0, 0);
  else { cameraContext.fillStyle = "#0b0d10"; cameraContext.fillRect(0, 0, camera.width, camera.height); }
  strokeBox(state.box, "#3fb950", false, "tracked");
  strokeBox(state.manualBox, "#f85149", false, "manual target");
  strokeBox(state.pendingBox, "#e3b341", true, "Enter: follow");
  if (state.drag) strokeBox(dragBox(), "#e3b341", true, "");
}

function imagePoint(event) {
  const rect = camera.getBoundingClientRect();
  return [
    Math.round(Math.min(Math.max(event.clientX - rect.left, 0), rect.width) * camera.width / rect.width),
    Math.round(Math.min(Math.max(event.clientY - rect.top, 0), rect.height) * camera.height / rect.height),
  ];
}

function dragBox() {
  const [x0, y0] = state.drag.from;
  const [x1, y1] = state.drag.to;
  return { x_offset: Math.min(x0, x1), y_offset: Math.min(y0, y1), width: Math.abs(x1 - x0), height: Math.abs(y1 - y0) };
}

camera.addEventListener("pointerdown", (event) => {
  camera.focus();
  camera.setPointerCapture(event.pointerId);
  const point = imagePoint(event);
  state.drag = { from: point, to: point };
  state.pendingBox = null;
  drawCamera();
});
camera.addEventListener("pointermove", (event) => {
  if (!state.drag) return;
  state.drag.to = imagePoint(event);
  drawCamera();
});
camera.addEventListener("pointerup", (event) => {
  if (!state.drag) return;
  state.drag.to = imagePoint(event);
  const box = dragBox();
  state.drag = null;
  state.pendingBox = box.width >= 4 && box.height >= 4 ? box : null;
  drawCamera();
});

function sendTarget() {
  const box = state.pendingBox;
  if (!box) return;
  bridge.publish(config.topics.manual_target.name, { ...box, do_rectify: false });
  state.manualBox = box;
  state.pendingBox = null;
  drawCamera();
}

// ---------------------------------------------------------------------------------------------- driving
const held = new Set();
let driveTimer = null;
let stopTimer = null;

function twist() {
  let forward = 0, turn = 0;
  for (const code of held) { forward += DRIVE_KEYS[code][0]; turn += DRIVE_KEYS[code][1]; }
  forward = Math.max(-1, Math.min(1, forward));
  turn = Math.max(-1, Math.min(1, turn));
  return { linear: { x: forward * config.drive.max_linear, y: 0, z: 0 },
           angular: { x: 0, y: 0, z: turn * config.drive.max_angular } };
}

function sendDrive() { bridge.publish(config.topics.cmd_vel.name, twist()); }

function releaseKeys() {
  if (held.size === 0) return;
  held.clear();
  showHeld();
  clearInterval(driveTimer);
  driveTimer = null;
  sendDrive();
}

function toggleStop() {
  const button = $("stop");
  if (stopTimer) {
    clearInterval(stopTimer);
    stopTimer = null;
    button.classList.remove("on");
    button.textContent = "Stop (Space)";
    return;
  }
  const send = () => bridge.publish(config.topics.stop.name, {});
  send();
  stopTimer = setInterval(send, 100);
  button.classList.add("on");
  button.textContent = "STOPPED (Space)";
}

function release() {
  releaseKeys();
  if (stopTimer) toggleStop();
  bridge.publish(config.topics.release.name, {});
  state.manualBox = null;
  state.pendingBox = null;
  drawCamera();
}

const PAD = { ArrowUp: "up", KeyW: "up", ArrowDown: "down", KeyS: "down", ArrowLeft: "left", KeyA: "left",
              ArrowRight: "right", KeyD: "right" };
function showHeld() {   // the pad shows what is held, from the keys or the pad itself
  const directions = new Set([...held].map((code) => PAD[code]));
  for (const button of document.querySelectorAll("#pad button")) {
    button.classList.toggle("held", directions.has(PAD[button.dataset.code]));
  }
}

function press(code) {
  if (held.has(code)) return;   // the keyboard's auto-repeat: the timer repeats instead
  held.add(code);
  showHeld();
  stats.keyEvents.push({ code, down: true, at: now() });
  sendDrive();
  if (!driveTimer) driveTimer = setInterval(sendDrive, config.drive.period_ms);
}

function lift(code) {
  if (!held.delete(code)) return;
  showHeld();
  stats.keyEvents.push({ code, down: false, at: now() });
  sendDrive();   // zero when nothing is held any more: the robot stops at once
  if (held.size === 0) { clearInterval(driveTimer); driveTimer = null; }
}

document.addEventListener("keydown", (event) => {
  if (!config || event.ctrlKey || event.altKey || event.metaKey) return;
  if (event.code in DRIVE_KEYS) {
    event.preventDefault();
    press(event.code);
  } else if (event.code === "Enter") {
    event.preventDefault();
    sendTarget();
  } else if (event.code === "Escape") {
    state.pendingBox = null;
    state.drag = null;
    drawCamera();
  } else if (event.code === "Space") {
    event.preventDefault();
    if (!event.repeat) toggleStop();
  } else if (event.code === "KeyR" && !event.repeat) {
    release();
  }
});
document.addEventListener("keyup", (event) => {
  if (!(event.code in DRIVE_KEYS) || !held.has(event.code)) return;
  event.preventDefault();
  lift(event.code);
});
// the on-screen pad (phones, tablets): held while the finger or the button stays down
for (const button of document.querySelectorAll("#pad button")) {
  const code = button.dataset.code;
  button.addEventListener("pointerdown", (event) => {
    if (!config) return;
    button.setPointerCapture(event.pointerId);
    press(code);
  });
  for (const kind of ["pointerup", "pointercancel", "lostpointercapture"]) {
    button.addEventListener(kind, () => lift(code));
  }
}
window.addEventListener("blur", releaseKeys);
document.addEventListener("visibilitychange", () => { if (document.hidden) releaseKeys(); });
$("stop").addEventListener("click", toggleStop);
$("release").addEventListener("click", release);

// ---------------------------------------------------------------------------------------------- map
const mapCanvas = $("map");
const mapContext = mapCanvas.getContext("2d");
let mapDrawQueued = false;

function onMap(msg) {
  const { width, height } = msg.info;
  const image = new ImageData(width, height);
  const data = msg.data;
  for (let row = 0; row < height; row++) {
    const target = (height - 1 - row) * width;   // row 0 is the lowest y: the bottom of the picture
    for (let col = 0; col < width; col++) {
      const value = data[row * width + col];
      const offset = (target + col) * 4;
      let shade;
      if (value < 0) { image.data[offset] = 52; image.data[offset + 1] = 58; image.data[offset + 2] = 68; }
      else {
        shade = 235 - Math.round(Math.min(value, 100) * 2.15);
        image.data[offset] = image.data[offset + 1] = image.data[offset + 2] = shade;
      }
      image.data[offset + 3] = 255;
    }
  }
  const offscreen = document.createElement("canvas");
  offscreen.width = width;
  offscreen.height = height;
  offscreen.getContext("2d").putImageData(image, 0, 0);
  state.map = msg.info;
  state.mapImage = offscreen;
  queueMapDraw();
}

function queueMapDraw() {
  if (mapDrawQueued) return;
  mapDrawQueued = true;
  requestAnimationFrame(() => { mapDrawQueued = false; drawMap(); });
}

function yaw(q) { return Math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)); }

function drawMap() {
  const ctx = mapContext;
  ctx.fillStyle = "#0b0d10";
  ctx.fillRect(0, 0, mapCanvas.width, mapCanvas.height);
  const info = state.map;
  if (!info) {
    ctx.fillStyle = "#8a94a3";
    ctx.font = "16px sans-serif";
    ctx.fillText("waiting for the map…", 20, 30);
    return;
  }
  const scale = Math.min(mapCanvas.width / info.width, mapCanvas.height / info.height);
  const left = (mapCanvas.width - info.width * scale) / 2;
  const top = (mapCanvas.height - info.height * scale) / 2;
  ctx.imageSmoothingEnabled = false;
  ctx.drawImage(state.mapImage, left, top, info.width * scale, info.height * scale);
  const res = info.resolution, origin = info.origin.position;
  const px = (x) => left + (x - origin.x) / res * scale;
  const py = (y) => top + (info.height - (y - origin.y) / res) * scale;
  const metre = scale / res;

  if (state.plan.length > 1) {
    ctx.strokeStyle = "#39c5cf"; ctx.lineWidth = 2.5; ctx.beginPath();
    state.plan.forEach((p, i) => (i ? ctx.lineTo : ctx.moveTo).call(ctx, px(p.x), py(p.y)));
    ctx.stroke();
  }
  ctx.font = "bold 12px sans-serif";
  state.goals.forEach((goal, i) => {
    ctx.fillStyle = "#e3b341";
    ctx.beginPath(); ctx.arc(px(goal.x), py(goal.y), Math.max(5, 0.12 * metre), 0, 2 * Math.PI); ctx.fill();
    ctx.fillStyle = "#15181d"; ctx.fillText(String(i + 1), px(goal.x) - 3.5, py(goal.y) + 4);
  });
  for (const alarm of state.alarms.values()) {
    if (alarm.x === null || alarm.y === null) continue;
    ctx.strokeStyle = "#ff7b29"; ctx.lineWidth = 3;
    ctx.beginPath(); ctx.arc(px(alarm.x), py(alarm.y), Math.max(9, 0.3 * metre), 0, 2 * Math.PI); ctx.stroke();
  }
  if (state.target) {
    const x = px(state.target.x), y = py(state.target.y), r = Math.max(7, 0.2 * metre);
    ctx.strokeStyle = "#f85149"; ctx.lineWidth = 2.5; ctx.beginPath();
    ctx.moveTo(x - r, y); ctx.lineTo(x + r, y); ctx.moveTo(x, y - r); ctx.lineTo(x, y + r); ctx.stroke();
    ctx.beginPath(); ctx.arc(x, y, r * 0.7, 0, 2 * Math.PI); ctx.stroke();
  }
  if (state.robot) {
    const { position, orientation } = state.robot;
    const heading = yaw(orientation), size = Math.max(9, 0.3 * metre);
    ctx.save();
    ctx.translate(px(position.x), py(position.y));
    ctx.rotate(-heading);   // the picture's y points down
    ctx.fillStyle = "#3fb950"; ctx.strokeStyle = "#0b0d10"; ctx.lineWidth = 1.5;
    ctx.beginPath(); ctx.moveTo(size, 0); ctx.lineTo(-size * 0.6, size * 0.6); ctx.lineTo(-size * 0.6, -size * 0.6);
    ctx.closePath(); ctx.fill(); ctx.stroke();
    ctx.restore();
  }
}

// ---------------------------------------------------------------------------------------------- network
const litNodes = new Map();   // arbiter name -> [svg elements to light]

async function loadNetwork() {
  if (!config.network) return;
  $("network-name").textContent = `${config.network.name}, levels 0..${config.network.level}`;
  const response = await fetch("network.svg");
  if (!response.ok) return;
  const holder = $("network");
  holder.innerHTML = await response.text();
  const svg = holder.querySelector("svg");
  svg.removeAttribute("width");
  svg.removeAttribute("height");
  const titleOf = (g) => (g.querySelector("title") || {}).textContent || "";
  for (const arbiter of config.arbiters) {
    const elements = [];
    for (const g of svg.querySelectorAll("g.node")) if (titleOf(g) === arbiter.node_id) elements.push(g);
    for (const g of svg.querySelectorAll("g.edge")) {   // the dashed upper line into the arbiter
      const path = g.querySelector("path");
      if (titleOf(g).endsWith(`->${arbiter.node_id}`) && path && path.getAttribute("stroke-dasharray")) elements.push(g);
    }
    litNodes.set(arbiter.name, elements);
    const row = document.createElement("tr");
    row.id = `arbiter-${arbiter.name}`;
    row.innerHTML = "<td class=mark></td><td class=name></td><td class=holder>no status yet</td>";
    row.querySelector(".mark").textContent = `${arbiter.letter} ${arbiter.units}`;
    row.querySelector(".name").textContent = `${arbiter.name} (upper: ${arbiter.upper})`;
    $("arbiters").tBodies[0].appendChild(row);
  }
}

function arbiterName(statusName) {
  const last = statusName.split("/").filter(Boolean).pop() || statusName;
  return last.includes(": ") ? last.split(": ").pop() : last;
}

function onArbiterStatus(status) {
  const values = Object.fromEntries((status.values || []).map((kv) => [kv.key, kv.value]));
  if (!("in_control" in values)) return;
  const name = arbiterName(status.name);
  const upper = values.in_control === "upper";
  state.arbiters.set(name, upper);
  for (const element of litNodes.get(name) || []) element.classList.toggle("lit", upper);
  const row = document.getElementById(`arbiter-${name}`);
  if (row) {
    row.classList.toggle("lit", upper);
    row.querySelector(".holder").textContent = upper ? "upper line holds control" : "lower line";
  }
}

// ---------------------------------------------------------------------------------------------- alarms
const LEVELS = ["ok", "warning", "error", "stale"];
function onAlarms(array) {
  for (const status of array.status || []) {
    const values = Object.fromEntries((status.values || []).map((kv) => [kv.key, kv.value]));
    const name = status.name || "alarm";
    const when = new Date().toLocaleTimeString();
    const log = document.createElement("li");
    if (status.level === 1 || status.level === 2) {
      const x = "x" in values ? parseFloat(values.x) : null, y = "y" in values ? parseFloat(values.y) : null;
      const isNew = !state.alarms.has(name);
      state.alarms.set(name, { name, text: status.message, level: status.level, x, y, when });
      if (!isNew) continue;
      log.className = "raised";
      log.textContent = `${when} ${LEVELS[status.level]}: ${name}: ${status.message}`;
    } else if (status.level === 0) {
      if (!state.alarms.delete(name)) continue;
      log.className = "cleared";
      log.textContent = `${when} cleared: ${name}${status.message ? ": " + status.message : ""}`;
    } else continue;
    $("alarms-log").prepend(log);
    while ($("alarms-log").children.length > 50) $("alarms-log").lastChild.remove();
  }
  const list = $("alarms-active");
  list.replaceChildren();
  for (const alarm of state.alarms.values()) {
    const item = document.createElement("li");
    item.className = alarm.level === 2 ? "error" : "warn";
    const where = alarm.x !== null && alarm.y !== null ? ` at (${alarm.x.toFixed(1)}, ${alarm.y.toFixed(1)})` : "";
    item.textContent = `${alarm.when} ${alarm.name}: ${alarm.text}${where}`;
    list.appendChild(item);
  }
  if (state.alarms.size === 0) {
    const item = document.createElement("li");
    item.className = "none";
    item.textContent = "no active alarm";
    list.appendChild(item);
  }
  $("alarm-count").textContent = state.alarms.size ? `${state.alarms.size} active` : "";
  queueMapDraw();
}

// ---------------------------------------------------------------------------------------------- start
function onTerminalStatus(status) {
  const values = Object.fromEntries((status.values || []).map((kv) => [kv.key, kv.value]));
  $("operator").textContent = `${status.message} · ${values.clients || 0} connected`;
}

let lastFrames = 0, lastTick = performance.now();
setInterval(() => {
  const t = performance.now();
  stats.fps = (stats.drawn - lastFrames) * 1000 / (t - lastTick);
  lastFrames = stats.drawn; lastTick = t;
  const recent = stats.latencies.slice(-30);
  const latency = recent.length ? recent.reduce((a, b) => a + b, 0) / recent.length * 1000 : NaN;
  $("stats").textContent = `${stats.fps.toFixed(1)} fps` + (isFinite(latency) ? ` · ${latency.toFixed(0)} ms` : "");
}, 1000);

async function start() {
  config = await (await fetch("config.json")).json();
  const topics = config.topics;
  $("title").textContent = `Operator terminal ${config.namespace !== "/" ? config.namespace : ""}`;
  $("camera-topic").textContent = topics.camera.name;
  const token = new URLSearchParams(location.search).get("token");
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  bridge = new Bridge(`${scheme}://${location.host}/`, {
    token,
    onStatus,
    onOpen: () => { $("connection").textContent = "connected"; $("connection").className = "badge ok"; },
    onClose: () => {
      $("connection").textContent = "disconnected"; $("connection").className = "badge bad";
      state.operator = false; $("control").textContent = "viewer"; $("control").className = "badge";
    },
  });
  const on = (role, callback, options) => bridge.subscribe(topics[role].name, topics[role].type, callback, options);
  // ?fps=N asks the terminal for at most N frames a second (rosbridge's throttle_rate): for a slow device
  const fps = parseFloat(new URLSearchParams(location.search).get("fps"));
  on("camera", onFrame, fps > 0 ? { throttle_rate: Math.round(1000 / fps) } : {});
  on("box", (roi) => { state.box = roi; drawCamera(); });
  on("manual_target", (roi) => { state.manualBox = roi; drawCamera(); });
  on("release", () => { state.manualBox = null; drawCamera(); });
  on("map", onMap);
  on("robot_pose", (msg) => { state.robot = msg.pose; queueMapDraw(); });
  on("goals", (msg) => { state.goals = msg.poses.map((p) => p.position); queueMapDraw(); });
  on("plan", (msg) => { state.plan = msg.poses.map((p) => p.pose.position); queueMapDraw(); });
  on("target", (msg) => { state.target = msg.point; queueMapDraw(); });
  on("alarms", onAlarms);
  on("diagnostics", (array) => (array.status || []).forEach(onArbiterStatus));
  on("status", onTerminalStatus);
  await loadNetwork();
  for (const arbiter of config.arbiters) {
    const role = `arbiter:${arbiter.name}`;
    if (topics[role]) on(role, onArbiterStatus);
  }
  drawCamera();
  drawMap();
  onAlarms({ status: [] });
}

start().catch((error) => notice(`the terminal could not start: ${error}`));
