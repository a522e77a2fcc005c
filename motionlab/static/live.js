// motionlab's live canvas (anywidget ES module; no build step, no network).
// mode "live": the kernel sends one frame per tick ({kind: "frame", p: 63 numbers, c: contacts,
//   fp: a new footprint [x, z], stats}); intents held down go back as the "held" trait
//   (not "keys": ipywidgets uses that name for the list of synced traits).
// mode "clip": the "clip" trait holds every frame once; the browser plays it in a loop.

const FEET = [3, 4, 7, 8];   // left ankle, left toe, right ankle, right toe (motionlab.skeleton.FEET)
const COLORS = { "tab:blue": "#1f77b4", "tab:red": "#d62728", black: "#111111" };
const KEYS = {
  ArrowUp: "forward", w: "forward", W: "forward",
  ArrowDown: "back", s: "back", S: "back",
  ArrowLeft: "left", a: "left", A: "left",
  ArrowRight: "right", d: "right", D: "right",
  q: "side_left", Q: "side_left", e: "side_right", E: "side_right",
  Shift: "run", " ": "stop",
};
const PAD = [["side_left", "Q"], ["forward", "\u2191"], ["side_right", "E"],
             ["left", "\u2190"], ["back", "\u2193"], ["right", "\u2192"],
             ["run", "run"], ["stop", "stop"]];

function el(tag, attrs = {}, text = "") {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) node.setAttribute(k, v);
  if (text) node.textContent = text;
  return node;
}

// A perspective camera at elevation 20 degrees, azimuth -60 (matplotlib's default 3-D view),
// 6 m from a target that follows the character.
function camera(target, width, height) {
  const el_ = (20 * Math.PI) / 180, az = (-60 * Math.PI) / 180, dist = 6.0;
  const dir = [Math.cos(el_) * Math.sin(az), Math.sin(el_), -Math.cos(el_) * Math.cos(az)];
  const eye = [target[0] + dist * dir[0], target[1] + dist * dir[1], target[2] + dist * dir[2]];
  const fwd = [-dir[0], -dir[1], -dir[2]];
  let r = [fwd[1] * 0 - fwd[2] * 1, fwd[2] * 0 - fwd[0] * 0, fwd[0] * 1 - fwd[1] * 0];
  const rn = Math.hypot(...r); r = r.map((x) => x / rn);
  const u = [r[1] * fwd[2] - r[2] * fwd[1], r[2] * fwd[0] - r[0] * fwd[2], r[0] * fwd[1] - r[1] * fwd[0]];
  const f = height * 1.9;
  return (p) => {
    const v = [p[0] - eye[0], p[1] - eye[1], p[2] - eye[2]];
    const depth = Math.max(0.1, v[0] * fwd[0] + v[1] * fwd[1] + v[2] * fwd[2]);
    return [width / 2 + (f * (v[0] * r[0] + v[1] * r[1] + v[2] * r[2])) / depth,
            height * 0.55 - (f * (v[0] * u[0] + v[1] * u[1] + v[2] * u[2])) / depth];
  };
}

function draw(ctx, state, bones, frame, overlay) {
  const { width, height } = ctx.canvas;
  ctx.fillStyle = "#ffffff";
  ctx.fillRect(0, 0, width, height);
  if (!frame) {
    ctx.fillStyle = "#555";
    ctx.font = "14px sans-serif";
    ctx.fillText(overlay.idle || "waiting for frames", 16, 28);
    return;
  }
  const hips = [frame[0], frame[1], frame[2]];
  // the camera eases after the character, so turns are seen, not jumped
  state.target = state.target
    ? state.target.map((t, i) => t + 0.15 * ([hips[0], 0.9, hips[2]][i] - t))
    : [hips[0], 0.9, hips[2]];
  const project = camera(state.target, width, height);
  const line = (a, b, color, w) => {
    const [x0, y0] = project(a), [x1, y1] = project(b);
    ctx.strokeStyle = color; ctx.lineWidth = w;
    ctx.beginPath(); ctx.moveTo(x0, y0); ctx.lineTo(x1, y1); ctx.stroke();
  };
  // floor grid, 0.5 m squares around the target
  const cx = Math.round(state.target[0] * 2) / 2, cz = Math.round(state.target[2] * 2) / 2;
  for (let k = -8; k <= 8; k++) {
    line([cx + k * 0.5, 0, cz - 4], [cx + k * 0.5, 0, cz + 4], "#e3e3e3", 1);
    line([cx - 4, 0, cz + k * 0.5], [cx + 4, 0, cz + k * 0.5], "#e3e3e3", 1);
  }
  // the path walked, on the floor
  const path = state.path;
  for (let k = 1; k < path.length; k++) line([path[k - 1][0], 0, path[k - 1][1]], [path[k][0], 0, path[k][1]], "#2ca02c", 2);
  // footprints: a small square where each toe landed, older ones fainter
  const prints = state.footprints;
  prints.forEach((p, k) => {
    const [x, y] = project([p[0], 0, p[1]]);
    ctx.fillStyle = `rgba(60, 60, 60, ${0.25 + (0.6 * (k + 1)) / prints.length})`;
    ctx.fillRect(x - 3, y - 2, 6, 4);
  });
  // the body
  const at = (j) => [frame[3 * j], frame[3 * j + 1], frame[3 * j + 2]];
  for (const [parent, child, color] of bones) line(at(parent), at(child), COLORS[color] || color, 3);
  // feet in contact: a dot under each joint the lock holds
  if (overlay.contacts) {
    FEET.forEach((j, k) => {
      if (!overlay.contacts[k]) return;
      const [x, y] = project([frame[3 * j], 0, frame[3 * j + 2]]);
      ctx.fillStyle = "#ff7f0e"; ctx.beginPath(); ctx.arc(x, y, 3, 0, 2 * Math.PI); ctx.fill();
    });
  }
  ctx.fillStyle = "#222"; ctx.font = "13px sans-serif";
  (overlay.lines || []).forEach((text, k) => ctx.fillText(text, 10, 20 + 17 * k));
  if (overlay.clamped) {
    ctx.fillStyle = "#b35900";
    ctx.fillText("control clamped to the range of the training data", 10, height - 30);
  }
  if (overlay.error) { ctx.fillStyle = "#c00000"; ctx.fillText(overlay.error, 10, height - 12); }
}

function render({ model, el: root }) {
  const mode = model.get("mode");
  const box = el("div", { tabindex: "0", class: "motionlab-live" });
  box.style.cssText = "outline: none; font: 13px sans-serif; max-width: 720px;";
  const canvas = el("canvas", { width: "720", height: "400" });
  canvas.style.cssText = "width: 100%; border: 1px solid #ccc; border-radius: 4px; cursor: pointer;";
  box.appendChild(canvas);
  root.appendChild(box);
  const ctx = canvas.getContext("2d");
  const state = { path: [], footprints: [], target: null };
  const overlay = { lines: [], error: "" };
  let frame = null, raf = 0, alive = true;
  const listeners = [];
  const listen = (node, type, fn, capture = false) => {
    node.addEventListener(type, fn, capture); listeners.push([node, type, fn, capture]);
  };

  const paint = () => { draw(ctx, state, model.get("bones"), frame, overlay); };

  if (mode === "clip") {
    let began = performance.now();
    const loop = () => {
      if (!alive) return;
      const clip = model.get("clip") || [];
      if (clip.length) {
        const fps = model.get("fps");
        const k = Math.floor(((performance.now() - began) / 1000) * fps) % clip.length;
        if (k === 0) state.path = [];
        frame = clip[k];
        state.path.push([frame[0], frame[2]]);
        overlay.lines = [model.get("title"), `t = ${(k / fps).toFixed(1)} s`];
      } else {
        frame = null; overlay.idle = "no clip";
      }
      paint();
      raf = requestAnimationFrame(loop);
    };
    const restart = () => { began = performance.now(); state.path = []; state.target = null; };
    model.on("change:clip", restart);
    raf = requestAnimationFrame(loop);
    return () => { alive = false; cancelAnimationFrame(raf); model.off("change:clip", restart); };
  }

  // ---- live mode: controls ------------------------------------------------------------------
  const bar = el("div"); bar.style.cssText = "display: flex; flex-wrap: wrap; gap: 8px; align-items: center; margin: 6px 0;";
  const play = el("button", { type: "button", title: "start or pause the character" });
  const reset = el("button", { type: "button", title: "back to standing at the start" }, "\u27f2 reset");
  const temperature = el("input", { type: "range", min: "0", max: "1", step: "0.05", title: "sampling temperature" });
  const tLabel = el("span");
  const variant = el("select", { title: "which shipped MoGlow generates" });
  for (const v of model.get("variants")) variant.appendChild(el("option", { value: v }, v));
  const lock = el("input", { type: "checkbox", title: "lock the feet (causal foot lock)" });
  const lockLabel = el("label"); lockLabel.append(lock, " feet locked");
  bar.append(play, reset, "temperature", temperature, tLabel, "model", variant, lockLabel);
  box.appendChild(bar);
  const pad = el("div"); pad.style.cssText = "display: grid; grid-template-columns: repeat(3, 52px); gap: 4px; user-select: none;";
  const held = new Set();
  // what the browser received and showed, for benchmarks/live.py --browser: arrival and paint
  // times of frames, and the delay from each key change to the first frame shown that the
  // kernel generated after it saw the change
  const record = { arrivals: [], shown: [], latencies: [], pending: null, seq: 0 };
  box.motionlab = record;
  const send = () => {
    record.seq += 1;
    record.pending = { seq: record.seq, at: performance.now() };
    model.set("held", [...held]); model.set("held_seq", record.seq); model.save_changes();
  };
  PAD.forEach(([intent, label], k) => {
    const b = el("button", { type: "button", title: intent.replace("_", " ") }, label);
    b.style.cssText = "height: 30px;";
    const down = (e) => { e.preventDefault(); held.add(intent); send(); };
    const up = () => { if (held.delete(intent)) send(); };
    listen(b, "pointerdown", down); listen(b, "pointerup", up); listen(b, "pointerleave", up);
    pad.appendChild(b);
  });
  const help = el("div", {}, "Click the picture (a blue frame: the keys now steer), then hold the arrows or " +
    "W A S D (turn with left / right), Q / E to side-step, Shift to run, Space to stop; Esc or a click " +
    "elsewhere gives the keys back to the notebook. Or hold the pad's buttons.");
  help.style.cssText = "color: #555; margin-top: 4px;";
  box.append(pad, help);

  const sync = () => {
    play.textContent = model.get("running") ? "\u2016 pause" : "\u25b6 start";
    temperature.value = model.get("temperature");
    tLabel.textContent = Number(model.get("temperature")).toFixed(2);
    variant.value = model.get("variant");
    lock.checked = model.get("lock_feet");
    overlay.error = model.get("error");
  };
  sync();
  for (const name of ["running", "temperature", "variant", "lock_feet", "error"]) model.on(`change:${name}`, sync);
  listen(play, "click", () => { model.set("running", !model.get("running")); model.save_changes(); });
  listen(reset, "click", () => { model.send({ kind: "reset" }); });
  listen(temperature, "input", () => { model.set("temperature", Number(temperature.value)); model.save_changes(); });
  listen(variant, "change", () => { model.set("variant", variant.value); model.save_changes(); });
  listen(lock, "change", () => { model.set("lock_feet", lock.checked); model.save_changes(); });

  // keys: a click on the picture arms the panel (a blue frame); until Esc or a click
  // elsewhere, its keys are caught on the window before anything else sees them, so the
  // notebook's own shortcuts (A, B, D D...) do not fire and no frontend's focus handling
  // (JupyterLab, Notebook 7, VS Code, Colab) can take them away
  let armed = false;
  const arm = (on) => {
    armed = on;
    canvas.style.outline = on ? "2px solid #1f77b4" : "none";
    if (!on && held.size) { held.clear(); send(); }
  };
  const key = (down) => (e) => {
    if (!armed) return;
    if (e.key === "Escape") { arm(false); return; }
    const intent = KEYS[e.key];
    if (!intent) return;
    e.preventDefault(); e.stopPropagation();
    if (down && !held.has(intent)) { held.add(intent); send(); }
    if (!down && held.delete(intent)) send();
  };
  listen(window, "keydown", key(true), true);
  listen(window, "keyup", key(false), true);
  listen(window, "pointerdown", (e) => { if (armed && !box.contains(e.target)) arm(false); }, true);
  listen(window, "blur", () => { if (held.size) { held.clear(); send(); } });   // keyups would be lost
  listen(canvas, "pointerdown", () => arm(true));

  // A playout buffer, as video calls have: frames leave the kernel every 1/fps s but reach the
  // page unevenly (the websocket, the browser's event loop). Frame j of a run is shown at
  // base + j / fps + DELAY, where base is the earliest any of the last WINDOW frames arrived
  // on that clock: a frame late by less than DELAY still shows on time, one later shows as it
  // arrives and the frames after it catch up over a few ticks, and the clock follows the
  // kernel's when it slows. Frames more than BACKLOG behind are skipped (never drawn), so the
  // picture never lags further; a pause starts a new run.
  const DELAY = 20, WINDOW = 40, BACKLOG = 3;
  const queue = [], offsets = [];
  let j = 0, last = -Infinity, shownAt = -Infinity;
  const apply = (msg) => {
    frame = msg.p;
    overlay.contacts = msg.c;
    overlay.clamped = Boolean(msg.x);
    state.path.push([msg.p[0], msg.p[2]]);
    if (state.path.length > 600) state.path.shift();
    if (msg.fp) { state.footprints.push(msg.fp); if (state.footprints.length > 40) state.footprints.shift(); }
    if (msg.stats) {
      const s = msg.stats, f = (x, d = 1) => (x === null || x === undefined ? "-" : Number(x).toFixed(d));
      overlay.lines = [`${f(s.fps)} frames/s delivered · ${f(s["ms per frame"], 2)} ms per frame generated`,
                       `frame interval p50 ${f(s["interval p50 (ms)"], 0)} ms, p99 ${f(s["interval p99 (ms)"], 0)} ms · ` +
                       `key to frame ${f(overlay.latency, 0)} ms`];
    }
  };
  const show = (msg, now) => {          // drawn: what a student sees, and what the benchmark times
    record.shown.push(now);
    if (record.shown.length > 20000) record.shown.splice(0, 10000);
    if (record.pending && msg.k >= record.pending.seq) {
      record.latencies.push(now - record.pending.at);
      overlay.latency = now - record.pending.at;
      record.pending = null;
    }
    apply(msg);
    paint();
  };
  const playout = () => {
    raf = 0;
    if (!alive) return;
    const now = performance.now(), period = 1000 / model.get("fps");
    while (queue.length > BACKLOG) apply(queue.shift());
    // at the display tick nearest its time; after a late frame, catch up over a few frames
    if (queue.length && now >= queue[0].due - 8 && now - shownAt >= 0.6 * period) {
      shownAt = now;
      show(queue.shift(), now);
    }
    if (queue.length) raf = requestAnimationFrame(playout);
  };
  const onMessage = (msg) => {
    if (msg.kind === "frame") {
      const now = performance.now(), period = 1000 / model.get("fps");
      record.arrivals.push(now);
      if (record.arrivals.length > 20000) record.arrivals.splice(0, 10000);
      if (now - last > 5 * period) { j = 0; offsets.length = 0; }   // the first frame, or after a pause
      last = now;
      offsets.push(now - j * period);
      if (offsets.length > WINDOW) offsets.shift();
      msg.due = Math.min(...offsets) + j * period + DELAY;
      j += 1;
      queue.push(msg);
      if (!raf) raf = requestAnimationFrame(playout);
    } else if (msg.kind === "reset") {
      queue.length = 0; offsets.length = 0; j = 0;
      state.path = []; state.footprints = []; state.target = null;
    } else if (msg.kind === "error") {
      overlay.error = msg.message;
      model.set("running", false); model.save_changes();
      paint();
    }
  };
  model.on("msg:custom", onMessage);
  overlay.idle = "press \u25b6 start, click here, then hold the arrow keys";
  paint();
  return () => {
    alive = false;
    cancelAnimationFrame(raf);
    model.off("msg:custom", onMessage);
    for (const name of ["running", "temperature", "variant", "lock_feet", "error"]) model.off(`change:${name}`, sync);
    for (const [node, type, fn, capture] of listeners) node.removeEventListener(type, fn, capture);
    try { model.send({ kind: "detached" }); } catch (e) { /* the kernel is gone */ }
  };
}

export default { render };
