// warp-hybrid viewer page: frames in over the WebSocket, the pointer out as the gaze.
// Messages follow /protocol.json (warp_hybrid/viewer/protocol.py); nothing is loaded from elsewhere.
"use strict";

const PROTOCOL_VERSION = 1;
const $ = (id) => document.getElementById(id);

// Keyboard and mouse: one table, used by the handlers and listed on the page.
const SHORTCUTS = [
  { keys: "pointer", what: "the gaze (cursor mode)" },
  { keys: "Shift + drag", what: "orbit the camera" },
  { keys: "Shift + Ctrl + drag", what: "pan the camera" },
  { keys: "Shift + wheel", what: "zoom the camera" },
  { key: "o", keys: "o", what: "overlay on/off", run: () => toggleOverlay() },
  { key: "m", keys: "m", what: "next mode (raster, hybrid, full)", run: () => cycle("mode") },
  { key: "w", keys: "w", what: "next window shape", run: () => cycle("shape") },
  { key: "c", keys: "c", what: "next camera", run: () => nextCamera() },
  { key: "0", keys: "0", what: "reset the view", run: () => send({ type: "reset_view" }) },
  { key: " ", keys: "space", what: "play / pause", run: () => togglePlay() },
  { key: "r", keys: "r", what: "record the gaze / stop", run: () => toggleRecord() },
  { key: "+", keys: "+ / -", what: "target FPS up / down by 5", run: () => stepFps(5) },
  { key: "-", run: () => stepFps(-5) },
  { key: "h", keys: "h", what: "HUD on/off", run: () => $("hud").classList.toggle("hidden") },
];

// What the page knows; the end-to-end test reads it too.
const state = {
  client: null, hello: null, header: null, frames: 0, errors: [], latencyMs: null,
  serverMs: null, latencySeq: null, overlay: true, seq: 0, recording: false, lastRecording: null,
};
window.viewerState = state;

const canvas = $("frame");
const ctx = canvas.getContext("2d");
let ws = null;
let pendingFrame = null;   // the newest frame not yet drawn (older ones are dropped)
let decoding = false;
let pointerPending = null; // the newest pointer position not yet sent
const arrivals = [];

function send(message) {
  if (ws && ws.readyState === WebSocket.OPEN) {
    ws.send(JSON.stringify({ v: PROTOCOL_VERSION, ...message }));
  }
}

function log(text) {
  $("log").textContent = text;
}

function connect() {
  ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
  ws.binaryType = "arraybuffer";
  ws.onopen = () => { $("status").textContent = "connected, waiting for frames"; };
  ws.onclose = () => {
    $("status").textContent = "disconnected; reconnecting";
    setTimeout(connect, 1000);
  };
  ws.onmessage = (event) => {
    if (typeof event.data === "string") {
      onJson(JSON.parse(event.data));
    } else {
      pendingFrame = event.data;
      drawNewest();
    }
  };
}

function onJson(message) {
  if (message.type === "hello") {
    onHello(message);
  } else if (message.type === "error") {
    state.errors.push(message.message);
    log(`refused: ${message.message}`);
  } else if (message.type === "event") {
    onEvent(message);
  }
}

function onHello(hello) {
  state.hello = hello;
  state.client = hello.client;
  $("scene-name").textContent = hello.scene;
  fillSelect($("mode"), hello.modes, hello.state.mode);
  fillSelect($("shape"), hello.shapes, hello.state.shape);
  fillSelect($("camera"), hello.cameras, hello.state.camera);
  const fields = Object.fromEntries(hello.protocol.messages.control.fields.map((f) => [f.name, f]));
  setRange($("fps"), fields.fps);
  setRange($("budget"), fields.budget_ms);
  $("fps").value = hello.state.fps.toFixed(0);
  $("budget").value = hello.state.budget_ms.toFixed(1);
  $("time-controls").hidden = !hello.animated;
  $("time").max = hello.duration;
  $("gaze-kind").textContent = hello.state.gaze;
  $("calibrate-link").hidden = hello.state.gaze !== "webcam";
  showProtocol(hello.protocol);
}

function onEvent(event) {
  if (event.name === "recording") {
    state.recording = true;
  } else if (event.name === "recorded") {
    state.recording = false;
    state.lastRecording = event;
    $("record-result").textContent = `saved ${event.trace} (${event.frames} frames); replay: ${event.replay}`;
  } else if (event.name === "calibration") {
    log(`calibration: ${event.state}`);
  }
  $("record").classList.toggle("active", state.recording);
  $("record").textContent = state.recording ? "stop recording" : "record";
}

function fillSelect(select, values, current) {
  select.replaceChildren(...values.map((v) => new Option(v, v, false, v === current)));
}

function setRange(input, field) {
  input.min = field.min;
  input.max = field.max;
}

function showProtocol(protocol) {
  const root = $("protocol");
  root.replaceChildren();
  const intro = document.createElement("p");
  intro.textContent = `Version ${protocol.v}; JSON objects {"v": ${protocol.v}, "type": ..., fields}, at most ${protocol.max_message_bytes} bytes.`;
  root.append(intro);
  for (const [name, spec] of Object.entries(protocol.messages)) {
    const head = document.createElement("div");
    const code = document.createElement("code");
    code.textContent = name;
    head.append(code, `: ${spec.doc}`);
    const list = document.createElement("ul");
    for (const f of spec.fields) {
      const item = document.createElement("li");
      const range = f.choices ? ` (${f.choices.join(", ")})` : f.min !== undefined ? ` [${f.min}, ${f.max}]` : "";
      item.textContent = `${f.name}${f.required ? "" : "?"}: ${f.kind}${range}: ${f.doc}`;
      list.append(item);
    }
    root.append(head, list);
  }
}

function showShortcuts() {
  $("shortcuts").replaceChildren(...SHORTCUTS.filter((s) => s.keys).map((s) => {
    const row = document.createElement("tr");
    const keys = document.createElement("td");
    const what = document.createElement("td");
    keys.textContent = s.keys;
    what.textContent = s.what;
    row.append(keys, what);
    return row;
  }));
}

// ---- frames ------------------------------------------------------------------------------

async function drawNewest() {
  if (decoding || pendingFrame === null) return;
  decoding = true;
  const data = pendingFrame;
  pendingFrame = null;
  try {
    const length = new DataView(data).getUint32(0);
    const header = JSON.parse(new TextDecoder().decode(new Uint8Array(data, 4, length)));
    const bitmap = await createImageBitmap(new Blob([new Uint8Array(data, 4 + length)], { type: "image/jpeg" }));
    if (canvas.width !== header.width || canvas.height !== header.height) {
      canvas.width = header.width;
      canvas.height = header.height;
    }
    ctx.drawImage(bitmap, 0, 0);
    bitmap.close();
    if (state.overlay) drawOverlay(header);
    onFrameShown(header);
  } finally {
    decoding = false;
    if (pendingFrame !== null) drawNewest();
  }
}

function drawOverlay(header) {
  const w = header.window;
  ctx.lineWidth = 1;
  if (w) {
    outline(w.centre, w.shape, w.half_w, w.half_h, "#ffff00");
    if (w.traced !== null && w.traced < w.half_w) {
      outline(w.centre, w.shape, w.traced, w.half_h * (w.traced / w.half_w), "#00ffff");
    }
  }
  const gx = header.gaze.x * header.width;
  const gy = header.gaze.y * header.height;
  ctx.strokeStyle = "#ff00ff";
  ctx.beginPath();
  ctx.moveTo(gx - 4, gy); ctx.lineTo(gx + 4, gy);
  ctx.moveTo(gx, gy - 4); ctx.lineTo(gx, gy + 4);
  ctx.stroke();
}

function outline(centre, shape, halfW, halfH, colour) {
  ctx.strokeStyle = colour;
  ctx.beginPath();
  if (shape === "circle") {
    ctx.arc(centre[0], centre[1], halfW, 0, 2 * Math.PI);
  } else {
    ctx.rect(centre[0] - halfW, centre[1] - halfH, 2 * halfW, 2 * halfH);
  }
  ctx.stroke();
}

function onFrameShown(header) {
  const now = performance.now();
  state.header = header;
  state.frames += 1;
  arrivals.push(now);
  while (arrivals.length > 30) arrivals.shift();
  const p = header.pointer;
  if (p && p.client === state.client && p.seq !== state.latencySeq) {
    // the first frame that shows this pointer move: its latency (later frames show it too)
    state.latencySeq = p.seq;
    state.latencyMs = now - p.sent_ms;
    state.serverMs = p.server_ms;
  }
  showHud(header);
  showState(header.state);
  $("status").textContent = `frame ${header.index}`;
}

function fixed(value, digits) {
  return value === null || value === undefined ? "–" : value.toFixed(digits);
}

function showHud(header) {
  const s = header.stats;
  const span = arrivals.length > 1 ? (arrivals[arrivals.length - 1] - arrivals[0]) / 1000 : 0;
  $("hud-fps").textContent = span > 0 ? ((arrivals.length - 1) / span).toFixed(1) : "–";
  $("hud-loop-fps").textContent = fixed(s.loop_fps, 1);
  $("hud-frame-ms").textContent = fixed(s.frame_ms, 1);
  $("hud-budget-ms").textContent = fixed(s.budget_ms, 1);
  const within = $("hud-within");
  within.textContent = s.within_budget ? "within budget" : s.infeasible ? "over (infeasible)" : "over budget";
  within.className = s.within_budget ? "ok" : "miss";
  $("hud-traced").textContent = fixed(100 * s.traced_fraction, 1);
  $("hud-window").textContent = fixed(100 * s.window_fraction, 1);
  $("hud-latency").textContent = fixed(state.latencyMs, 0);
  $("hud-server-ms").textContent = fixed(state.serverMs, 0);
  $("hud-gaze").textContent = `${header.gaze.x.toFixed(3)}, ${header.gaze.y.toFixed(3)}${header.gaze.valid ? "" : " (invalid)"}`;
  const rows = Object.entries(s.stages_ms).map(([name, ms]) => {
    const row = document.createElement("tr");
    const a = document.createElement("td");
    const b = document.createElement("td");
    a.textContent = name;
    b.textContent = ms.toFixed(2);
    row.append(a, b);
    return row;
  });
  $("hud-stages").replaceChildren(...rows);
}

function showState(s) {
  for (const [id, value] of [["mode", s.mode], ["shape", s.shape], ["camera", s.camera]]) {
    if (document.activeElement !== $(id)) $(id).value = value;
  }
  if (document.activeElement !== $("fps")) $("fps").value = s.fps.toFixed(0);
  if (document.activeElement !== $("budget")) $("budget").value = s.budget_ms.toFixed(1);
  $("play").textContent = s.playing ? "pause" : "play";
  if (document.activeElement !== $("time")) $("time").value = s.t;
  $("time-label").textContent = `${s.t.toFixed(2)} s`;
  state.recording = s.recording;
  $("record").classList.toggle("active", s.recording);
  $("record").textContent = s.recording ? "stop recording" : "record";
}

// ---- controls ----------------------------------------------------------------------------

function current() {
  return state.header ? state.header.state : state.hello.state;
}

function cycle(field) {
  const values = field === "mode" ? state.hello.modes : state.hello.shapes;
  const now = current()[field];
  const next = values[(values.indexOf(now) + 1) % values.length];
  send({ type: "control", [field]: next });
}

function nextCamera() {
  const cams = state.hello.cameras;
  if (cams.length > 1) send({ type: "camera", name: cams[(cams.indexOf(current().camera) + 1) % cams.length] });
}

function togglePlay() {
  if (state.hello.animated) send({ type: "play", playing: !current().playing });
}

function toggleRecord() {
  send({ type: "record", action: state.recording ? "stop" : "start" });
}

function toggleOverlay() {
  state.overlay = !state.overlay;
  $("overlay").checked = state.overlay;
}

function stepFps(delta) {
  const field = state.hello.protocol.messages.control.fields.find((f) => f.name === "fps");
  const fps = Math.min(field.max, Math.max(field.min, Math.round(current().fps) + delta));
  send({ type: "control", fps });
}

function bindControls() {
  $("fps").addEventListener("change", () => send({ type: "control", fps: Number($("fps").value) }));
  $("budget").addEventListener("change", () => send({ type: "control", budget_ms: Number($("budget").value) }));
  $("mode").addEventListener("change", () => send({ type: "control", mode: $("mode").value }));
  $("shape").addEventListener("change", () => send({ type: "control", shape: $("shape").value }));
  $("camera").addEventListener("change", () => send({ type: "camera", name: $("camera").value }));
  $("overlay").addEventListener("change", () => { state.overlay = $("overlay").checked; });
  $("reset-view").addEventListener("click", () => send({ type: "reset_view" }));
  $("play").addEventListener("click", togglePlay);
  $("time").addEventListener("input", () => send({ type: "seek", t: Number($("time").value) }));
  $("record").addEventListener("click", toggleRecord);
  document.addEventListener("keydown", (event) => {
    if (event.target instanceof HTMLInputElement || event.target instanceof HTMLSelectElement) return;
    const key = event.key === "=" ? "+" : event.key;
    const shortcut = SHORTCUTS.find((s) => s.key === key);
    if (shortcut && state.hello && !event.ctrlKey && !event.altKey && !event.metaKey) {
      event.preventDefault();
      shortcut.run();
    }
  });
}

// ---- pointer: the gaze, or a camera drag with the modifier held ---------------------------

// The pointer on the frame, normalised (origin top-left), the canvas letterboxed by object-fit: contain.
function normalised(event) {
  const rect = canvas.getBoundingClientRect();
  const scale = Math.min(rect.width / canvas.width, rect.height / canvas.height);
  const w = canvas.width * scale;
  const h = canvas.height * scale;
  return {
    x: Math.min(1, Math.max(0, (event.clientX - rect.left - (rect.width - w) / 2) / w)),
    y: Math.min(1, Math.max(0, (event.clientY - rect.top - (rect.height - h) / 2) / h)),
  };
}

let drag = null;

function bindPointer() {
  canvas.addEventListener("pointerdown", (event) => {
    if (!event.shiftKey) return;
    drag = { ...normalised(event), kind: event.ctrlKey ? "pan" : "orbit" };
    canvas.setPointerCapture(event.pointerId);
    canvas.classList.add("navigating");
  });
  canvas.addEventListener("pointerup", () => { drag = null; canvas.classList.remove("navigating"); });
  canvas.addEventListener("pointermove", (event) => {
    const p = normalised(event);
    if (drag) {
      send({ type: "navigate", kind: drag.kind, dx: p.x - drag.x, dy: p.y - drag.y });
      drag.x = p.x;
      drag.y = p.y;
      return;
    }
    if (state.hello && state.hello.state.gaze === "cursor") {
      if (pointerPending === null) requestAnimationFrame(flushPointer);
      pointerPending = p;
    }
  });
  canvas.addEventListener("wheel", (event) => {
    if (!event.shiftKey) return;
    event.preventDefault();
    const delta = (event.deltaY || event.deltaX) > 0 ? 0.05 : -0.05;
    send({ type: "navigate", kind: "zoom", dx: 0, dy: delta });
  }, { passive: false });
}

function flushPointer() {
  if (pointerPending === null) return;
  state.seq += 1;
  send({ type: "pointer", x: pointerPending.x, y: pointerPending.y, seq: state.seq, sent_ms: performance.now() });
  pointerPending = null;
}

showShortcuts();
bindControls();
bindPointer();
connect();
