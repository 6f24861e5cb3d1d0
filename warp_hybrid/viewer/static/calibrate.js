// Webcam calibration page: shows the server's 9 targets in turn (warp_hybrid/viewer/calibration.py).
"use strict";

const $ = (id) => document.getElementById(id);
const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);

function send(message) {
  ws.send(JSON.stringify({ v: 1, ...message }));
}

function finish(text) {
  $("target").hidden = true;
  $("intro").hidden = false;
  $("result").textContent = text;
  if (document.fullscreenElement) document.exitFullscreen();
}

ws.onmessage = (event) => {
  if (typeof event.data !== "string") return; // frames are not shown here
  const message = JSON.parse(event.data);
  if (message.type === "hello" && message.state.gaze !== "webcam") {
    $("start").disabled = true;
    $("result").textContent = "The viewer's gaze is not the webcam: start it with --gaze webcam:INDEX.";
  } else if (message.type === "error") {
    finish(`refused: ${message.message}`);
  } else if (message.type === "event" && message.name === "calibration") {
    if (message.state === "target") {
      $("intro").hidden = true;
      const target = $("target");
      target.hidden = false;
      target.style.left = `${100 * message.x}%`;
      target.style.top = `${100 * message.y}%`;
    } else if (message.state === "done") {
      finish(`Saved ${message.path} (residual ${message.residual_rms.toFixed(4)} of the screen); the webcam now drives the gaze.`);
    } else {
      finish(`Calibration ${message.state}${message.message ? ": " + message.message : ""}.`);
    }
  }
};

$("start").addEventListener("click", async () => {
  try {
    await document.documentElement.requestFullscreen();
  } catch (err) {
    // full screen refused (e.g. in a frame): the targets still span the window
  }
  send({ type: "calibrate", action: "start" });
});
document.addEventListener("keydown", (event) => {
  if (event.key === "Escape") send({ type: "calibrate", action: "cancel" });
});
