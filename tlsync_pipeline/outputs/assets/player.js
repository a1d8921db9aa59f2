// tlsync synchronized player: one shared position on the target's clock drives every camera's video.
// Data: the JSON in <script id="tlsync-player-data"> (see tlsync_pipeline/outputs/player.py).
// Position: the target sample s (seconds t0 + s / rate). A camera's clock is alpha * s + beta
// (frame index, or presentation time x clock_fps for VFR cameras); its frame is the nearest frame
// to that clock, and its video seeks to the middle of that frame's display interval. A recording that
// breaks (c.segments) adds a shift per segment: its frame is the one a segment of known shift holds at
// clock - shift (CameraClock.frames_at); none there, and a segment of unknown shift spans the position:
// "no picture: unknown segment" rather than a wrong frame.
(function () {
  "use strict";
  const holder = document.getElementById("tlsync-player-data");
  if (!holder) return;
  const data = JSON.parse(holder.textContent);
  const target = data.target;
  const root = document.getElementById("player");
  const slider = document.getElementById("player-slider");
  const clockLabel = document.getElementById("player-time");
  const playButton = document.getElementById("player-play");
  const stepSelect = document.getElementById("player-step-camera");

  function decodeTimes(t) {
    if (t.deltas_us) {
      const out = new Float64Array(t.deltas_us.length + 1);
      let us = 0;
      out[0] = t.start;
      for (let i = 0; i < t.deltas_us.length; i++) { us += t.deltas_us[i]; out[i + 1] = t.start + us * 1e-6; }
      return out;
    }
    const out = new Float64Array(t.n);
    for (let i = 0; i < t.n; i++) out[i] = t.start + t.step * i;
    return out;
  }

  const cameras = data.cameras.map(function (c) {
    const times = decodeTimes(c.times);
    const n = times.length;
    const interval = n > 1 ? (times[n - 1] - times[0]) / (n - 1) : (c.fps ? 1 / c.fps : 0.04);
    return Object.assign({}, c, { times: times, n: n, interval: interval });
  });

  // Nearest frame (0-based) to a steady clock value, or -1 outside the recording.
  function steadyFrame(c, clock) {
    if (c.clock_fps) {
      const t = clock / c.clock_fps, times = c.times;
      if (t < times[0] - c.interval / 2 || t > times[c.n - 1] + c.interval / 2) return -1;
      let lo = 0, hi = c.n - 1;
      while (hi - lo > 1) { const mid = (lo + hi) >> 1; if (times[mid] <= t) lo = mid; else hi = mid; }
      return (t - times[lo] <= times[hi] - t) ? lo : hi;
    }
    const f = Math.round(clock);
    return (f >= 0 && f < c.n) ? f : -1;
  }

  // The camera's frame at target sample s and its segment's shift: frame -1 when the camera is not recording,
  // -2 in a segment of unknown shift (segment: its row).
  function locate(c, s) {
    const clock = c.alpha * s + c.beta;
    if (!c.segments) return { frame: steadyFrame(c, clock), shift: 0 };
    const last = c.segments.length - 1;
    for (let k = 0; k <= last; k++) {
      const g = c.segments[k];
      if (g.shift === null) continue;
      const f = steadyFrame(c, clock - g.shift);
      if (f >= 0 && (k === 0 || f >= g.start) && (k === last || f < g.stop)) return { frame: f, shift: g.shift };
    }
    const unknown = c.segments.find(function (g) {
      return g.shift === null && (g.lo === null || s >= g.lo) && (g.hi === null || s <= g.hi);
    });
    return { frame: unknown ? -2 : -1, shift: 0, segment: unknown };
  }

  function frameAt(c, s) { return locate(c, s).frame; }

  function frameLabel(f) {
    return f >= 0 ? "frame " + f : (f === -2 ? "no picture: unknown segment" : "not recording");
  }

  // The video time (s) that shows frame f: the middle of its display interval.
  function seekTime(c, f) {
    const next = f + 1 < c.n ? c.times[f + 1] : c.times[f] + c.interval;
    return c.times[f] + (next - c.times[f]) / 2;
  }

  // The shift of frame f's segment (0 without segments; null: unknown).
  function shiftOf(c, f) {
    if (!c.segments) return 0;
    const last = c.segments.length - 1;
    const g = c.segments.find(function (g, k) { return (k === 0 || f >= g.start) && (k === last || f < g.stop); });
    return g ? g.shift : null;
  }

  // The target sample at which frame f of camera c was taken (NaN: its segment's shift is unknown).
  function sampleOfFrame(c, f) {
    const shift = shiftOf(c, f);
    if (shift === null) return NaN;
    const clock = (c.clock_fps ? c.times[f] * c.clock_fps : f) + shift;
    return (clock - c.beta) / c.alpha;
  }

  // Continuous video time at target sample s (for playback drift checks).
  function videoTime(c, s) {
    const clock = c.alpha * s + c.beta - locate(c, s).shift;
    if (c.clock_fps) return clock / c.clock_fps;
    const i = Math.max(0, Math.min(c.n - 2, Math.floor(clock)));
    return c.n > 1 ? c.times[i] + (clock - i) * (c.times[i + 1] - c.times[i]) : c.times[0];
  }

  function pathPoint(c, s) {
    const p = c.path, k = (s - p.start) / p.step, i = Math.floor(k), m = p.uv.length / 2;
    if (i < 0 || i >= m) return null;
    const j = Math.min(i + 1, m - 1), w = k - i;
    const u0 = p.uv[2 * i], v0 = p.uv[2 * i + 1], u1 = p.uv[2 * j], v1 = p.uv[2 * j + 1];
    if (u0 === null || u1 === null) return null;
    return [((1 - w) * u0 + w * u1) / 10, ((1 - w) * v0 + w * v1) / 10];
  }

  function formatTime(s) {
    if (!target.seconds) return "sample " + s.toFixed(2);
    const t = target.t0 + s / target.rate;
    if (target.utc) return new Date(t * 1000).toISOString().replace("T", " ").replace("Z", " UTC");
    return "t = " + t.toFixed(3) + " s";
  }

  // Views: one per camera.
  const grid = document.getElementById("player-views");
  const views = cameras.map(function (c) {
    const box = document.createElement("figure");
    box.className = "view";
    const stage = document.createElement("div");
    stage.className = "stage";
    stage.style.aspectRatio = c.size[0] + " / " + c.size[1];
    let video = null;
    if (c.src) {
      video = document.createElement("video");
      video.muted = true;
      video.preload = "auto";
      video.playsInline = true;
      video.src = c.src;
      video.dataset.camera = c.name;
      video.addEventListener("error", function () {
        note.textContent = "cannot play " + c.src + (c.codec ? " (" + c.codec + ")" : "") + ": render with proxy = \"always\"";
        box.classList.add("unplayable");
      });
      stage.appendChild(video);
    }
    const canvas = document.createElement("canvas");
    stage.appendChild(canvas);
    const caption = document.createElement("figcaption");
    const title = document.createElement("b");
    title.textContent = c.name;
    const label = document.createElement("span");
    const note = document.createElement("span");
    note.className = "note";
    caption.append(title, " ", label, " ", note);
    if (!c.src) note.textContent = "no video: projected path only";
    else if (c.proxy) note.textContent = "proxy clip";
    box.append(stage, caption);
    let cursor = null, place = null;
    if (c.segments) {
      // The recording's strip over the slider's range: segments of known shift, breaks, the current position.
      const strip = document.createElement("div");
      strip.className = "strip";
      const at = function (s) { return (100 * (s - data.range[0]) / (data.range[1] - data.range[0] || 1)) + "%"; };
      c.segments.forEach(function (g) {
        if (g.shift === null || g.lo === null) return;
        const bar = document.createElement("span");
        bar.className = "segment" + (g.source === "line" ? " line" : "");
        bar.style.left = at(g.lo);
        bar.style.width = "calc(" + at(g.hi) + " - " + at(g.lo) + ")";
        strip.appendChild(bar);
      });
      c.breaks.forEach(function (b) {
        const mark = document.createElement("span");
        mark.className = "break";
        mark.style.left = at(b.sample);
        mark.title = b.text;
        strip.appendChild(mark);
      });
      cursor = document.createElement("span");
      cursor.className = "cursor";
      strip.appendChild(cursor);
      place = at;
      box.appendChild(strip);
    }
    grid.appendChild(box);
    box.addEventListener("click", function () { stepSelect.value = c.name; });
    return {
      camera: c, box: box, video: video, canvas: canvas, frameLabel: label, cursor: cursor, place: place, frame: -1,
    };
  });

  function drawOverlay(view, s) {
    const c = view.camera, canvas = view.canvas;
    const w = canvas.clientWidth, h = canvas.clientHeight;
    if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    const ctx = canvas.getContext("2d");
    ctx.clearRect(0, 0, w, h);
    const kx = w / c.size[0], ky = h / c.size[1];
    ctx.strokeStyle = "rgba(255, 60, 60, 0.45)";
    ctx.lineWidth = 1;
    ctx.beginPath();
    let pen = false;
    for (let i = 0; i < c.path.uv.length; i += 2) {
      const u = c.path.uv[i], v = c.path.uv[i + 1];
      if (u === null) { pen = false; continue; }
      if (pen) ctx.lineTo(u / 10 * kx, v / 10 * ky); else ctx.moveTo(u / 10 * kx, v / 10 * ky);
      pen = true;
    }
    ctx.stroke();
    const p = pathPoint(c, s);
    if (p) {
      ctx.strokeStyle = "#ff2020";
      ctx.lineWidth = 2;
      ctx.beginPath();
      ctx.arc(p[0] * kx, p[1] * ky, 9, 0, 2 * Math.PI);
      ctx.stroke();
      ctx.beginPath();
      ctx.moveTo(p[0] * kx - 14, p[1] * ky); ctx.lineTo(p[0] * kx - 5, p[1] * ky);
      ctx.moveTo(p[0] * kx + 5, p[1] * ky); ctx.lineTo(p[0] * kx + 14, p[1] * ky);
      ctx.stroke();
    }
  }

  let position = data.range[0];
  let playing = false, wall0 = 0, position0 = 0;

  function mark(view, f, s) {
    view.frame = f;
    view.box.classList.toggle("idle", f < 0);
    view.frameLabel.textContent = frameLabel(f);
    if (view.cursor) view.cursor.style.left = view.place(s);
  }

  function show(view, s, seek) {
    const c = view.camera, f = frameAt(c, s);
    mark(view, f, s);
    if (view.video && f >= 0 && seek) view.video.currentTime = seekTime(c, f);
    if (view.video && f < 0 && !view.video.paused) view.video.pause();
    drawOverlay(view, s);
  }

  function setPosition(s, seek) {
    position = Math.max(data.range[0], Math.min(data.range[1], s));
    slider.value = position;
    clockLabel.textContent = formatTime(position);
    views.forEach(function (v) { show(v, position, seek); });
  }

  function tick() {
    if (!playing) return;
    const s = position0 + (performance.now() - wall0) / 1000 * target.rate;
    if (s >= data.range[1]) { pause(); return; }
    position = s;
    slider.value = s;
    clockLabel.textContent = formatTime(s);
    views.forEach(function (view) {
      const c = view.camera, f = frameAt(c, s);
      mark(view, f, s);
      if (view.video) {
        if (f < 0) { if (!view.video.paused) view.video.pause(); }
        else if (view.video.paused) { view.video.currentTime = videoTime(c, s); view.video.play().catch(function () {}); }
        else if (Math.abs(view.video.currentTime - videoTime(c, s)) > Math.max(3 * c.interval, 0.15)) view.video.currentTime = videoTime(c, s);
      }
      drawOverlay(view, s);
    });
    requestAnimationFrame(tick);
  }

  function play() {
    if (playing) return;
    if (position >= data.range[1]) position = data.range[0];
    playing = true;
    playButton.textContent = "pause";
    wall0 = performance.now();
    position0 = position;
    views.forEach(function (view) {
      const c = view.camera;
      if (view.video) view.video.playbackRate = c.alpha * target.rate / (c.clock_fps || c.fps || (1 / c.interval));
    });
    requestAnimationFrame(tick);
  }

  function pause() {
    playing = false;
    playButton.textContent = "play";
    views.forEach(function (view) { if (view.video) view.video.pause(); });
    setPosition(position, true);
  }

  function step(direction) {
    if (playing) pause();
    const view = views.find(function (v) { return v.camera.name === stepSelect.value; }) || views[0];
    const c = view.camera, f = frameAt(c, position);
    if (f < 0) { setPosition(position + direction / c.alpha, true); return; }
    let next = Math.max(0, Math.min(c.n - 1, f + direction));
    while (isNaN(sampleOfFrame(c, next)) && next + direction >= 0 && next + direction < c.n) next += direction;
    if (!isNaN(sampleOfFrame(c, next))) setPosition(sampleOfFrame(c, next), true);
  }

  cameras.forEach(function (c) {
    const option = document.createElement("option");
    option.value = option.textContent = c.name;
    stepSelect.appendChild(option);
  });
  if (data.reference) stepSelect.value = data.reference;
  slider.min = data.range[0];
  slider.max = data.range[1];
  slider.step = "any";
  slider.addEventListener("input", function () { if (playing) pause(); setPosition(parseFloat(slider.value), true); });
  playButton.addEventListener("click", function () { if (playing) pause(); else play(); });
  document.getElementById("player-back").addEventListener("click", function () { step(-1); });
  document.getElementById("player-forward").addEventListener("click", function () { step(1); });
  document.addEventListener("keydown", function (event) {
    if (event.target && /INPUT|SELECT|TEXTAREA/.test(event.target.tagName) && event.target !== slider) return;
    if (event.key === "ArrowRight" || event.key === ".") { step(1); event.preventDefault(); }
    else if (event.key === "ArrowLeft" || event.key === ",") { step(-1); event.preventDefault(); }
    else if (event.key === " ") { if (playing) pause(); else play(); event.preventDefault(); }
  });
  window.addEventListener("resize", function () { views.forEach(function (v) { drawOverlay(v, position); }); });

  // Start in the middle of the reference camera's recording.
  const first = cameras.find(function (c) { return c.name === data.reference; }) || cameras[0];
  const middle = first ? sampleOfFrame(first, Math.floor(first.n / 2)) : NaN;
  setPosition(isNaN(middle) ? (data.range[0] + data.range[1]) / 2 : middle, true);
  root.classList.add("ready");
  window.tlsyncPlayer = {
    setPosition: setPosition, frameAt: frameAt, locate: locate, seekTime: seekTime, sampleOfFrame: sampleOfFrame,
    step: step, views: views, get position() { return position; },
  };
})();
