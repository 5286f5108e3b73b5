// mlayer view: the page's script. Written for mlayer; no third-party code, works offline.
//
// The server (mlayer/viewer/server.py) sends joint positions as base64 float32 arrays; this
// script draws them as stick figures with Canvas 2D through a small perspective camera of its
// own (orbit by drag, zoom by wheel), plays them, and asks the server to recompute the
// processed motion whenever a control changes (one request in flight at a time; a change made
// meanwhile is sent when the answer arrives).
//
// For tests, window.mlayerViewer exposes the state, the world positions last drawn, and
// play/pause/setFrame.
"use strict";

(function () {
  const $ = (id) => document.getElementById(id);
  const PARTS = ["arms", "legs", "spine"];
  const COLORS = { left: [38, 110, 200], right: [205, 60, 50], center: [70, 70, 78] };
  // the session token the server put in the page: every /api/ request carries it (the
  // X-Mlayer-Token header for fetch, token= for the download link and the layer image)
  const TOKEN = (document.querySelector('meta[name="mlayer-token"]') || {}).content || "";
  const withToken = (url) => `${url}${url.includes("?") ? "&" : "?"}token=${encodeURIComponent(TOKEN)}`;

  const S = {
    clips: [], clip: -1, orig: null, proc: null,
    playing: true, t: 0, speed: 1, layout: "side",
    cam: { yaw: 0.7, pitch: 0.28, dist: 0, zoom: 1 },
    linked: { arms: true, legs: true, spine: true },
    inflight: false, pending: false, requests: 0, responses: 0, ready: false,
    lastError: null, lastQuery: "", drawn: null, pngClip: -1, target: null,
  };

  // ---------- data ----------

  function b64bytes(b64) {
    const s = atob(b64);
    const u = new Uint8Array(s.length);
    for (let i = 0; i < s.length; i++) u[i] = s.charCodeAt(i);
    return u;
  }
  const f32 = (b64) => new Float32Array(b64bytes(b64).buffer);

  function decodeMotion(d, nPoints) {
    const nc = (d.contact_names || S.orig.contactNames).length;
    return {
      frames: d.frames, fps: d.fps, duration: d.duration, nPoints: nPoints,
      pos: f32(d.positions), cpos: f32(d.contact_points), contacts: b64bytes(d.contacts),
      nContacts: nc, metrics: d.metrics,
    };
  }

  async function getJSON(url) {
    const r = await fetch(url, { cache: "no-store", headers: { "X-Mlayer-Token": TOKEN } });
    let body = null;
    try { body = await r.json(); } catch (e) { body = { error: `HTTP ${r.status}` }; }
    if (!r.ok) throw new Error(body && body.error ? body.error : `HTTP ${r.status}`);
    return body;
  }

  function status(text, kind) {
    const el = $("status");
    el.textContent = text;
    el.className = kind || "";
  }

  // ---------- clips ----------

  async function start() {
    bindControls();
    bindManifold();
    let list;
    try {
      list = (await getJSON("/api/clips")).clips;
    } catch (e) {
      status(`cannot reach the server: ${e.message}`, "bad");
      return;
    }
    S.clips = list;
    const sel = $("clip");
    const bad = [];
    for (const c of list) {
      const o = document.createElement("option");
      o.value = c.index;
      o.textContent = c.error ? `${c.name} (failed to load)` : c.name;
      o.disabled = !!c.error;
      sel.appendChild(o);
      if (c.error) bad.push(`${c.name}: ${c.error}`);
    }
    if (bad.length) {
      $("errors").hidden = false;
      $("errors").textContent = bad.join("\n");
    }
    const good = list.filter((c) => !c.error);
    if (!good.length) {
      status("no clip could be loaded (see the errors above)", "bad");
      $("main").hidden = true;
      S.ready = true;
      return;
    }
    sel.value = good[0].index;
    await loadClip(good[0].index);
    requestAnimationFrame(tick);
  }

  async function loadClip(i) {
    S.clip = +i;
    S.ready = false;
    status("loading clip…", "busy");
    let d;
    try {
      d = await getJSON(`/api/clip?clip=${S.clip}`);
    } catch (e) {
      status(e.message, "bad");
      return;
    }
    const o = decodeMotion(d, d.n_points);
    Object.assign(o, {
      name: d.name, parents: d.parents, sides: d.sides, parts: d.parts,
      jointNames: d.joint_names, contactNames: d.contact_names, height: d.height,
      plotJoint: d.plot_joint, decomposeMs: d.decompose_ms,
    });
    o.nJoints = d.joint_names.length;
    let ymin = Infinity;
    for (let k = 1; k < o.pos.length; k += 3) ymin = Math.min(ymin, o.pos[k]);
    o.floor = ymin;
    S.orig = o;
    S.proc = null;
    S.cam.dist = 0;
    S.target = null;
    // the joint list of the layer chart, the part sizes
    const js = $("joint");
    js.textContent = "";
    d.joint_names.forEach((n, j) => {
      const op = document.createElement("option");
      op.value = j;
      op.textContent = n;
      js.appendChild(op);
    });
    js.value = d.plot_joint;
    const count = (p) => d.parts.filter((x) => x === p).length;
    $("parts-note").textContent =
      `joints per part: arms ${count("arms")}, legs ${count("legs")}, spine and head ${count("spine")}` +
      (d.contact_names.length ? `; contacts on ${d.contact_names.join(", ")}` : "; no feet found");
    $("slide-orig").textContent = fmt(d.metrics.sliding);
    $("jitter-orig").textContent = fmt(d.metrics.jitter);
    $("frames-orig").textContent = `${d.frames} @ ${fpsText(d.fps)}`;
    $("layers-png").removeAttribute("src");
    S.pngClip = -1;
    if ($("figure-details").open) showPng();
    request();
  }

  // ---------- requests ----------

  function query() {
    const q = new URLSearchParams();
    q.set("clip", S.clip);
    q.set("alpha", $("alpha").value);
    const keys = $("alpha-keys").value.trim();
    if (keys) q.set("keys", keys);
    for (const p of PARTS) if (!S.linked[p]) q.set(p, $(p).value);
    q.set("denoise", $("denoise").checked ? "1" : "0");
    q.set("contacts", $("contacts").checked ? "1" : "0");
    const ratio = +$("length").value;
    if (Math.abs(ratio - 1) > 1e-9) q.set("length", (ratio * S.orig.duration).toFixed(6));
    if (+$("warp").value > 0) q.set("warp", $("warp").value);
    if ($("fps").value) q.set("fps", $("fps").value);
    q.set("joint", $("joint").value);
    return q.toString();
  }

  function request() {
    if (!S.orig) return;
    if (S.inflight) { S.pending = true; return; }
    S.inflight = true;
    S.pending = false;
    S.requests++;
    const q = query();
    const clip = S.clip;
    const t0 = performance.now();
    status("computing…", "busy");
    getJSON(`/api/process?${q}`).then((d) => {
      if (clip !== S.clip) return;
      const u = phase();
      S.proc = decodeMotion(d, d.n_points);
      S.proc.plot = d.plot;
      S.proc.alphaCurve = d.alpha_curve;
      S.t = u * S.proc.duration;
      S.lastQuery = q;
      S.lastError = null;
      $("download").href = withToken(`/api/download?${q}`);
      $("download").classList.remove("disabled");
      $("slide-proc").textContent = fmt(d.metrics.sliding);
      $("jitter-proc").textContent = fmt(d.metrics.jitter);
      $("frames-proc").textContent = `${d.frames} @ ${fpsText(d.fps)}`;
      const rt = performance.now() - t0;
      $("timing").textContent =
        (d.cached ? "cached on the server" : `computed in ${d.compute_ms.toFixed(0)} ms on the server`) +
        ` (${rt.toFixed(0)} ms round trip); ` +
        `decomposition ${S.orig.decomposeMs.toFixed(0)} ms, once per clip. Units: body heights per s (sliding), per s³ (jitter).`;
      $("scrub").max = S.proc.frames - 1;
      status(`${S.orig.name} · ${S.orig.frames} frames · ${S.orig.jointNames.length} joints`);
      drawChart();
      S.responses++;
      S.ready = true;
    }).catch((e) => {
      S.lastError = e.message;
      S.responses++;
      status(e.message, "bad");
    }).finally(() => {
      S.inflight = false;
      if (S.pending) request();
    });
  }

  const fpsText = (f) => f.toFixed(2).replace(/\.?0+$/, "");

  function fmt(v) {
    if (v === null || v === undefined) return "n/a";
    return Math.abs(v) >= 1000 ? v.toExponential(2) : v.toPrecision(3);
  }

  // ---------- controls ----------

  function bindControls() {
    $("clip").addEventListener("change", (e) => loadClip(e.target.value));
    $("alpha").addEventListener("input", () => {
      $("alpha-out").textContent = (+$("alpha").value).toFixed(2);
      for (const p of PARTS) if (S.linked[p]) $(p).value = $("alpha").value;
      request();
    });
    for (const p of PARTS) {
      $(p).addEventListener("input", () => {
        S.linked[p] = false;
        $(`${p}-out`).textContent = (+$(p).value).toFixed(2);
        request();
      });
    }
    $("alpha-keys").addEventListener("change", request);
    $("key-alpha").addEventListener("click", keyAlpha);
    $("clear-keys").addEventListener("click", () => { $("alpha-keys").value = ""; request(); });
    $("reset-parts").addEventListener("click", () => {
      for (const p of PARTS) {
        S.linked[p] = true;
        $(p).value = $("alpha").value;
        $(`${p}-out`).textContent = "=";
      }
      request();
    });
    for (const id of ["denoise", "contacts", "fps", "joint"]) $(id).addEventListener("change", request);
    $("length").addEventListener("input", () => {
      const r = +$("length").value;
      $("length-out").textContent = S.orig ? `${(r * S.orig.duration).toFixed(1)} s` : `${r.toFixed(2)}×`;
      request();
    });
    $("warp").addEventListener("input", () => {
      $("warp-out").textContent = (+$("warp").value).toFixed(1);
      request();
    });
    $("play").addEventListener("click", () => (S.playing ? pause() : play()));
    $("scrub").addEventListener("input", () => setFrame(+$("scrub").value));
    $("speed").addEventListener("change", () => { S.speed = +$("speed").value; });
    $("layout").addEventListener("change", () => { S.layout = $("layout").value; });
    $("figure-details").addEventListener("toggle", () => { if ($("figure-details").open) showPng(); });
    $("download").classList.add("disabled");

    const cv = $("figure");
    let drag = null;
    cv.addEventListener("pointerdown", (e) => {
      drag = { x: e.clientX, y: e.clientY };
      cv.setPointerCapture(e.pointerId);
      cv.classList.add("dragging");
    });
    cv.addEventListener("pointermove", (e) => {
      if (!drag) return;
      S.cam.yaw -= (e.clientX - drag.x) * 0.008;
      S.cam.pitch = Math.max(-0.2, Math.min(1.45, S.cam.pitch + (e.clientY - drag.y) * 0.006));
      drag = { x: e.clientX, y: e.clientY };
    });
    const up = () => { drag = null; cv.classList.remove("dragging"); };
    cv.addEventListener("pointerup", up);
    cv.addEventListener("pointercancel", up);
    cv.addEventListener("wheel", (e) => {
      e.preventDefault();
      S.cam.zoom = Math.max(0.15, Math.min(8, S.cam.zoom * Math.exp(e.deltaY * 0.0015)));
    }, { passive: false });
    cv.addEventListener("dblclick", () => { S.cam.yaw = 0.7; S.cam.pitch = 0.28; S.cam.zoom = 1; });
  }

  function showPng() {
    if (S.pngClip === S.clip || S.clip < 0) return;
    S.pngClip = S.clip;
    $("layers-png").src = withToken(`/api/layers.png?clip=${S.clip}`);
  }

  function play() { S.playing = true; $("play").textContent = "pause"; }
  function pause() { S.playing = false; $("play").textContent = "play"; }
  function setFrame(f) {
    if (!S.proc) return;
    S.t = Math.max(0, Math.min(S.proc.frames - 1, f)) / S.proc.fps;
  }
  function phase() {
    if (!S.proc) return 0;
    return S.proc.frames > 1 ? procFrame() / (S.proc.frames - 1) : 0;
  }
  function procFrame() {
    if (!S.proc) return 0;
    return Math.min(S.proc.frames - 1, Math.max(0, Math.floor(S.t * S.proc.fps + 1e-6)));
  }

  // ---------- camera ----------

  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const norm = (a) => { const l = Math.hypot(a[0], a[1], a[2]) || 1; return [a[0] / l, a[1] / l, a[2] / l]; };

  function camera(target, w, h, height, cam) {
    const c = cam || S.cam;
    height = height || S.orig.height;
    const dist = 2.6 * height * c.zoom;
    const eye = [target[0] + dist * Math.cos(c.pitch) * Math.sin(c.yaw), target[1] + dist * Math.sin(c.pitch),
      target[2] + dist * Math.cos(c.pitch) * Math.cos(c.yaw)];
    const f = norm(sub(target, eye));
    const r = norm(cross(f, [0, 1, 0]));
    const u = cross(r, f);
    const focal = h / (2 * Math.tan((40 * Math.PI) / 360));
    const near = 0.02 * height;
    return { eye, f, r, u, focal, near, cx: w / 2, cy: h * 0.55 };
  }
  function toCam(cam, p) { const d = sub(p, cam.eye); return [dot(d, cam.r), dot(d, cam.u), dot(d, cam.f)]; }
  function toScreen(cam, c) { return [cam.cx + (cam.focal * c[0]) / c[2], cam.cy - (cam.focal * c[1]) / c[2]]; }
  function segment(ctx, cam, a, b) {
    let ca = toCam(cam, a), cb = toCam(cam, b);
    if (ca[2] < cam.near && cb[2] < cam.near) return;
    if (ca[2] < cam.near || cb[2] < cam.near) {
      const s = (cam.near - ca[2]) / (cb[2] - ca[2]);
      const m = [ca[0] + s * (cb[0] - ca[0]), ca[1] + s * (cb[1] - ca[1]), cam.near];
      if (ca[2] < cam.near) ca = m; else cb = m;
    }
    const sa = toScreen(cam, ca), sb = toScreen(cam, cb);
    ctx.moveTo(sa[0], sa[1]);
    ctx.lineTo(sb[0], sb[1]);
  }

  // ---------- drawing ----------

  function point(m, f, k, off) {
    const i = (f * m.nPoints + k) * 3;
    return [m.pos[i] + off[0], m.pos[i + 1], m.pos[i + 2] + off[2]];
  }

  function drawFigure(ctx, cam, m, f, off, faded, label) {
    const o = m.sk || S.orig;  // the skeleton: the clip's, or a manifold motion's own
    ctx.lineCap = "round";
    for (let k = 1; k < m.nPoints; k++) {
      const p = o.parents[k];
      if (p < 0) continue;
      const c = COLORS[o.sides[k]] || COLORS.center;
      ctx.strokeStyle = `rgba(${c[0]},${c[1]},${c[2]},${faded ? 0.4 : 1})`;
      ctx.lineWidth = faded ? 2.5 : 3.5;
      ctx.beginPath();
      segment(ctx, cam, point(m, f, p, off), point(m, f, k, off));
      ctx.stroke();
    }
    ctx.fillStyle = faded ? "rgba(20,20,20,0.35)" : "#141414";
    for (let k = 0; k < o.nJoints; k++) {
      const c = toCam(cam, point(m, f, k, off));
      if (c[2] < cam.near) continue;
      const s = toScreen(cam, c);
      ctx.beginPath();
      ctx.arc(s[0], s[1], faded ? 1.6 : 2.2, 0, 2 * Math.PI);
      ctx.fill();
    }
    // foot contacts: green discs on the contact points
    for (let c = 0; c < m.nContacts; c++) {
      if (!m.contacts[f * m.nContacts + c]) continue;
      const i = (f * m.nContacts + c) * 3;
      const cc = toCam(cam, [m.cpos[i] + off[0], m.cpos[i + 1], m.cpos[i + 2] + off[2]]);
      if (cc[2] < cam.near) continue;
      const s = toScreen(cam, cc);
      const r = Math.max(3, (cam.focal * 0.025 * o.height) / cc[2]);
      ctx.fillStyle = faded ? "rgba(30,160,70,0.45)" : "rgba(30,160,70,0.9)";
      ctx.beginPath();
      ctx.arc(s[0], s[1], r, 0, 2 * Math.PI);
      ctx.fill();
    }
    if (label) {
      let top = -Infinity;
      for (let k = 0; k < m.nPoints; k++) top = Math.max(top, m.pos[(f * m.nPoints + k) * 3 + 1]);
      const head = toCam(cam, [point(m, f, 0, off)[0], top + 0.1 * o.height, point(m, f, 0, off)[2]]);
      if (head[2] > cam.near) {
        const s = toScreen(cam, head);
        ctx.fillStyle = "#333";
        ctx.font = "13px system-ui, sans-serif";
        ctx.textAlign = "center";
        ctx.fillText(label, s[0], s[1]);
      }
    }
  }

  function niceStep(x) {
    const p = Math.pow(10, Math.floor(Math.log10(x)));
    const m = x / p;
    return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
  }

  function drawGrid(ctx, cam, center, o) {
    o = o || S.orig;
    const step = niceStep(o.height / 2);
    const K = 14;
    const cx = Math.round(center[0] / step) * step, cz = Math.round(center[2] / step) * step;
    ctx.strokeStyle = "#d6d6d0";
    ctx.lineWidth = 1;
    ctx.beginPath();
    for (let i = -K; i <= K; i++) {
      for (let s = -K; s < K; s++) {  // short pieces so lines behind the camera clip cleanly
        segment(ctx, cam, [cx + i * step, o.floor, cz + s * step], [cx + i * step, o.floor, cz + (s + 1) * step]);
        segment(ctx, cam, [cx + s * step, o.floor, cz + i * step], [cx + (s + 1) * step, o.floor, cz + i * step]);
      }
    }
    ctx.stroke();
  }

  function resizeCanvas(cv) {
    const dpr = window.devicePixelRatio || 1;
    const w = Math.round(cv.clientWidth * dpr), h = Math.round(cv.clientWidth * dpr * 0.5);
    if (cv.width !== w || cv.height !== h) { cv.width = w; cv.height = h; }
  }

  let last = null;
  function tick(now) {
    const dt = last === null ? 0 : Math.min(0.1, (now - last) / 1000);
    last = now;
    if (S.proc && S.playing) {
      S.t += dt * S.speed;
      if (S.t * S.proc.fps > S.proc.frames - 1 + 1e-6) S.t = 0;
    }
    draw();
    manifoldTick(dt);
    requestAnimationFrame(tick);
  }

  function draw() {
    const cv = $("figure");
    resizeCanvas(cv);
    const ctx = cv.getContext("2d");
    ctx.fillStyle = "#ffffff";
    ctx.fillRect(0, 0, cv.width, cv.height);
    const o = S.orig, p = S.proc;
    if (!o || !p) return;
    const fp = procFrame();
    const fo = p.frames > 1 ? Math.round((fp / (p.frames - 1)) * (o.frames - 1)) : 0;
    // the camera follows the original's root over the ground, smoothly
    const root = point(o, fo, 0, [0, 0, 0]);
    const want = [root[0], o.floor + 0.5 * o.height, root[2]];
    if (!S.target) S.target = want;
    else for (let a = 0; a < 3; a++) S.target[a] += 0.15 * (want[a] - S.target[a]);
    const cam = camera(S.target, cv.width, cv.height);
    drawGrid(ctx, cam, S.target);
    const gap = S.layout === "side" ? 0.45 * o.height : 0;
    const right = norm([cam.r[0], 0, cam.r[2]]);
    const offO = [-gap * right[0], 0, -gap * right[2]], offP = [gap * right[0], 0, gap * right[2]];
    const side = S.layout === "side";
    if (S.layout !== "processed") drawFigure(ctx, cam, o, fo, offO, !side, side ? "original" : null);
    drawFigure(ctx, cam, p, fp, offP, false, side ? "processed" : null);
    $("scrub").value = fp;
    $("time").textContent = `${fp + 1} / ${p.frames} · ${(fp / p.fps).toFixed(2)} s`;
    const grab = (m, f) => Array.from({ length: o.nJoints }, (_, k) => point(m, f, k, [0, 0, 0]));
    S.drawn = { procFrame: fp, origFrame: fo, processed: grab(p, fp), original: grab(o, fo) };
    drawCursor();
  }

  // ---------- layer chart ----------

  function drawChart() {
    const cv = $("chart");
    const dpr = window.devicePixelRatio || 1;
    cv.width = Math.round(cv.clientWidth * dpr);
    cv.height = Math.round(200 * dpr);
    const ctx = cv.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    const W = cv.width / dpr, H = cv.height / dpr;
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, W, H);
    const pl = S.proc && S.proc.plot;
    if (!pl) return;
    const curves = [pl.original, pl.base, pl.control, pl.processed];
    let lo = Infinity, hi = -Infinity;
    for (const c of curves) for (const v of c) { if (v < lo) lo = v; if (v > hi) hi = v; }
    if (!(hi > lo)) { lo -= 1; hi += 1; }
    const pad = 0.06 * (hi - lo);
    lo -= pad; hi += pad;
    const tmax = Math.max(pl.t[pl.t.length - 1] || 1, pl.t_processed[pl.t_processed.length - 1] || 1);
    const L = 46, R = 10, T = 10, B = 24;
    const X = (t) => L + ((W - L - R) * t) / tmax, Y = (v) => T + ((H - T - B) * (hi - v)) / (hi - lo);
    ctx.strokeStyle = "#ccc";
    ctx.fillStyle = "#555";
    ctx.font = "11px system-ui, sans-serif";
    ctx.lineWidth = 1;
    const ys = niceStep((hi - lo) / 4);
    ctx.textAlign = "right";
    for (let v = Math.ceil(lo / ys) * ys; v <= hi; v += ys) {
      ctx.beginPath(); ctx.moveTo(L, Y(v)); ctx.lineTo(W - R, Y(v)); ctx.stroke();
      ctx.fillText(`${+v.toFixed(6)}°`, L - 4, Y(v) + 4);
    }
    const xs = niceStep(tmax / 8);
    ctx.textAlign = "center";
    for (let t = 0; t <= tmax + 1e-9; t += xs) ctx.fillText(`${+t.toFixed(3)} s`, X(t), H - 6);
    const line = (ts, vs, color, width, dash) => {
      ctx.strokeStyle = color; ctx.lineWidth = width; ctx.setLineDash(dash || []);
      ctx.beginPath();
      vs.forEach((v, i) => (i ? ctx.lineTo(X(ts[i]), Y(v)) : ctx.moveTo(X(ts[i]), Y(v))));
      ctx.stroke();
      ctx.setLineDash([]);
    };
    line(pl.t, pl.original, "#8c8c8c", 2.4);
    line(pl.t, pl.base, "#1f77b4", 1.3);
    line(pl.t, pl.control, "#9467bd", 1.1, [5, 3]);
    line(pl.t_processed, pl.processed, "#d62728", 1.3);
    S.chart = { X, Y, W, H, T, B, image: ctx.getImageData(0, 0, cv.width, cv.height) };
    drawAlphaChart(L, R, tmax);
  }

  // ---------- alpha over time: the keys of the global alpha, and its curve under the chart ----------

  function parseKeys(text) {  // [[t, a], ...] of "t:a,t:a" (the server checks them)
    return text.split(",").map((k) => k.split(":").map(Number))
      .filter((k) => k.length === 2 && Number.isFinite(k[0]) && Number.isFinite(k[1]));
  }

  function keyAlpha() {  // a key at the playhead's input time with the global alpha's value
    if (!S.orig || !S.drawn) return;
    const t = +(S.drawn.origFrame / S.orig.fps).toFixed(3);
    const a = +(+$("alpha").value).toFixed(2);
    const keys = parseKeys($("alpha-keys").value).filter((k) => Math.abs(k[0] - t) > 1e-6);
    keys.push([t, a]);
    keys.sort((x, y) => x[0] - y[0]);
    $("alpha-keys").value = keys.map((k) => `${k[0]}:${k[1]}`).join(",");
    request();
  }

  function drawAlphaChart(L, R, tmax) {
    const cv = $("alpha-chart");
    const ac = S.proc && S.proc.alphaCurve;
    cv.hidden = !ac;
    S.alphaChart = null;
    if (!ac) return;
    const dpr = window.devicePixelRatio || 1;
    cv.width = Math.round(cv.clientWidth * dpr);
    cv.height = Math.round(70 * dpr);
    const ctx = cv.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    const W = cv.width / dpr, H = cv.height / dpr, T = 6, B = 14;
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, W, H);
    let hi = 1;
    for (const v of ac.alpha) hi = Math.max(hi, v);
    for (const k of ac.keys) hi = Math.max(hi, k[1]);
    const X = (t) => L + ((W - L - R) * Math.min(t, tmax)) / tmax, Y = (v) => T + ((H - T - B) * (hi - v)) / hi;
    ctx.strokeStyle = "#ccc"; ctx.lineWidth = 1;
    ctx.fillStyle = "#555"; ctx.font = "11px system-ui, sans-serif"; ctx.textAlign = "right";
    for (const v of [0, 1, hi]) {
      ctx.beginPath(); ctx.moveTo(L, Y(v)); ctx.lineTo(W - R, Y(v)); ctx.stroke();
      ctx.fillText(`α ${+v.toFixed(2)}`, L - 4, Y(v) + 4);
    }
    ctx.strokeStyle = "#2ca02c"; ctx.lineWidth = 1.6;
    ctx.beginPath();
    ac.alpha.forEach((v, i) => (i ? ctx.lineTo(X(ac.t[i]), Y(v)) : ctx.moveTo(X(ac.t[i]), Y(v))));
    ctx.stroke();
    ctx.fillStyle = "#2ca02c";
    for (const k of ac.keys) { ctx.beginPath(); ctx.arc(X(k[0]), Y(k[1]), 3.5, 0, 2 * Math.PI); ctx.fill(); }
    S.alphaChart = { X, T, B, H, image: ctx.getImageData(0, 0, cv.width, cv.height) };
  }

  function drawCursor() {  // the current time on the chart
    const ch = S.chart;
    if (!ch || !S.proc) return;
    const ctx = $("chart").getContext("2d");
    ctx.putImageData(ch.image, 0, 0);
    const x = ch.X(procFrame() / S.proc.fps);
    ctx.strokeStyle = "rgba(0,0,0,0.5)";
    ctx.lineWidth = 1;
    ctx.beginPath(); ctx.moveTo(x, ch.T); ctx.lineTo(x, ch.H - ch.B); ctx.stroke();
    const ac = S.alphaChart;
    if (ac && S.orig && S.drawn) {  // the input time of the frame shown
      const c2 = $("alpha-chart").getContext("2d");
      c2.putImageData(ac.image, 0, 0);
      const xa = ac.X(S.drawn.origFrame / S.orig.fps);
      c2.strokeStyle = "rgba(0,0,0,0.5)";
      c2.lineWidth = 1;
      c2.beginPath(); c2.moveTo(xa, ac.T); c2.lineTo(xa, ac.H - ac.B); c2.stroke();
    }
  }


  // ---------- the motion manifold (paper 2: the SOM lattice, primitives, synthesis) ----------
  //
  // /api/manifold?train=1 starts the training on the server; the page polls /api/manifold until
  // the map arrives, then draws the lattice (U-matrix in grey, each unit tinted by its
  // primitive), the training clips' trajectories, the primitives' centres and the transition
  // matrix. A click on the map adds a lattice point; the spline through the points, the key
  // frames' BMUs or a generated primitive sequence come back as a motion with its path, played
  // in its own figure (one request in flight; the newest waiting one is sent next).

  const PALETTE = [[31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189],
    [140, 86, 75], [227, 119, 194], [127, 127, 127], [188, 189, 34], [23, 190, 207]];
  const colorOf = (i) => {
    const c = PALETTE[i % PALETTE.length];
    const k = Math.floor(i / PALETTE.length) % 3;
    return k === 0 ? c : c.map((v) => Math.round(k === 1 ? v * 0.6 : 255 - (255 - v) * 0.5));
  };
  const M = {
    state: "idle", map: null, points: [], keys: [], motion: null, t: 0, playing: true,
    requests: 0, responses: 0, inflight: false, pending: null, lastError: null, lastQuery: "",
    lastKind: null, drawn: null, target: null, mapImage: null,
    keyPoses: null, column: null, overlay: null, strip: null, stripImage: null,
    cam: { yaw: 0.7, pitch: 0.28, zoom: 1 },
  };

  function bindManifold() {
    $("m-train").addEventListener("click", manifoldTrain);
    $("m-map").addEventListener("click", (e) => {
      if (!M.map) return;
      const rect = $("m-map").getBoundingClientRect();
      const p = toLattice(e.clientX - rect.left, e.clientY - rect.top);
      M.points.push(p);
      manifoldRequest("points");
    });
    $("m-clear").addEventListener("click", () => { M.points = []; drawMapOverlay(); });
    $("m-play").addEventListener("click", () => {
      M.playing = !M.playing;
      $("m-play").textContent = M.playing ? "pause" : "play";
    });
    $("m-frames").addEventListener("change", () => { if (M.lastKind) manifoldRequest(M.lastKind); });
    $("m-guards").addEventListener("change", () => { if (M.lastKind) manifoldRequest(M.lastKind); });
    $("m-poses").addEventListener("change", () => drawMapOverlay());
    window.addEventListener("resize", () => { if (M.motion) drawStrip(); });
    $("m-noise").addEventListener("input", () => {
      $("m-noise-out").textContent = (+$("m-noise").value).toFixed(2);
    });
    $("m-noise").addEventListener("change", () => { if (M.lastKind === "start") manifoldRequest("start"); });
    for (const id of ["m-key-clip", "m-start-clip"]) {
      $(id).addEventListener("change", () => setFrameMax(id));
    }
    $("m-key-add").addEventListener("click", () => {
      M.keys.push(`${$("m-key-clip").value}:${Math.max(0, Math.floor(+$("m-key-frame").value))}`);
      $("m-keys").textContent = M.keys.join(", ");
    });
    $("m-key-clear").addEventListener("click", () => { M.keys = []; $("m-keys").textContent = "none"; });
    $("m-key-go").addEventListener("click", () => { if (M.keys.length) manifoldRequest("keys"); });
    $("m-generate").addEventListener("click", () => manifoldRequest("start"));
    $("m-download").classList.add("disabled");
  }

  function setFrameMax(id) {
    const c = S.clips.find((x) => String(x.index) === $(id).value);
    const input = $(id === "m-key-clip" ? "m-key-frame" : "m-start-frame");
    if (c) input.max = c.frames - 1;
  }

  function mStatus(text, kind) {
    $("m-status").textContent = text;
    $("m-status").className = kind || "";
  }

  async function manifoldTrain() {
    if (M.state === "training" || M.state === "ready") return;
    M.state = "training";
    $("m-train").disabled = true;
    let d;
    try {
      d = await getJSON("/api/manifold?train=1");
      while (d.state === "training") {
        const last = d.steps.length ? d.steps[d.steps.length - 1] : "starting";
        mStatus(`learning… ${Math.round(100 * d.progress)}% · ${last}`, "busy");
        await new Promise((r) => setTimeout(r, 300));
        d = await getJSON("/api/manifold");
      }
    } catch (e) {
      d = { state: "failed", error: e.message };
    }
    M.state = d.state;
    if (d.state !== "ready") {
      mStatus(`the manifold could not be learned: ${d.error}`, "bad");
      $("m-train").disabled = false;
      return;
    }
    M.map = d;
    $("m-train").hidden = true;
    $("m-body").hidden = false;
    const ex = d.excluded.length ? ` · left out: ${d.excluded.map((e) => `${e.name} (${e.reason})`).join(", ")}` : "";
    mStatus(`SOM ${d.rows}×${d.cols} on ${d.frames} frames (every ${d.stride}. frame of ${d.clips.length} clip(s)), ` +
      `${d.k} primitives, learned in ${d.seconds.toFixed(1)} s${ex}`);
    for (const id of ["m-key-clip", "m-start-clip"]) {
      const sel = $(id);
      sel.textContent = "";
      for (const i of d.clips) {
        const o = document.createElement("option");
        o.value = i;
        o.textContent = S.clips[i] ? S.clips[i].name : `clip ${i}`;
        sel.appendChild(o);
      }
      setFrameMax(id);
    }
    $("m-frames").max = d.max_frames;
    const cyc = (c) => c.map((p) => p.join("→")).join(", ");
    $("m-cycles").textContent = `most likely next (eq. 5): ${cyc(d.cycles.most)}; second most likely: ${cyc(d.cycles.second)}`;
    M.keyPoses = f32(d.key_poses);
    drawMapBase();
    drawTransitions();
    drawKeyColumn(-1);
  }

  function manifoldQuery(kind) {
    const q = new URLSearchParams();
    if (kind === "points") q.set("points", M.points.map((p) => `${p[0].toFixed(3)},${p[1].toFixed(3)}`).join(";"));
    else if (kind === "keys") q.set("keys", M.keys.join(","));
    else {
      q.set("start", `${$("m-start-clip").value}:${Math.max(0, Math.floor(+$("m-start-frame").value))}`);
      q.set("chain", $("m-chain").value);
      if (+$("m-noise").value > 0) q.set("noise", $("m-noise").value);
      q.set("seed", Math.max(0, Math.floor(+$("m-seed").value)));
    }
    q.set("frames", Math.max(3, Math.floor(+$("m-frames").value)));
    if (!$("m-guards").checked) q.set("guards", "0");
    return q.toString();
  }

  function manifoldRequest(kind) {
    if (!M.map) return;
    if (kind === "points" && !M.points.length) return;
    M.lastKind = kind;
    const q = manifoldQuery(kind);
    drawMapOverlay();
    if (M.inflight) { M.pending = kind; return; }
    M.inflight = true;
    M.pending = null;
    M.requests++;
    mStatus("computing the motion…", "busy");
    getJSON(`/api/manifold/motion?${q}`).then((d) => {
      const m = decodeMotion(d, d.n_points);
      m.sk = { parents: d.parents, sides: d.sides, nJoints: d.joint_names.length, height: d.height };
      let ymin = Infinity;
      for (let k = 1; k < m.pos.length; k += 3) ymin = Math.min(ymin, m.pos[k]);
      m.sk.floor = ymin;
      Object.assign(m, { kind: d.kind, traj: d.trajectory, knots: d.knots, primitives: d.primitives,
        knotTimes: d.knot_times, k: d.k, memberships: f32(d.memberships), membership: d.membership });
      M.motion = m;
      M.t = 0;
      M.target = null;
      M.lastQuery = q;
      M.lastError = null;
      $("m-download").href = withToken(`/api/manifold/download?${q}`);
      $("m-download").classList.remove("disabled");
      const what = d.kind === "points" ? `the spline through ${d.knots.length} point(s)` :
        d.kind === "keys" ? `the spline through the BMUs of ${d.knots.length} key frame(s)` :
          `from training frame ${d.start_training_frame}`;
      $("m-info").textContent = `${what}: ${d.frames} frames @ ${fpsText(d.fps)} fps, primitives ${d.primitives.join(" → ")}; ` +
        `computed in ${d.compute_ms.toFixed(0)} ms`;
      drawStrip();
      mStatus("");
      M.responses++;
    }).catch((e) => {
      M.lastError = e.message;
      M.responses++;
      mStatus(e.message, "bad");
    }).finally(() => {
      M.inflight = false;
      if (M.pending) manifoldRequest(M.pending);
    });
  }

  // map geometry: unit (r, c) is drawn at the centre of cell c from the left, row r from the
  // bottom (as `mlayer primitives`' figure); canvas pixels <-> lattice coordinates
  function mapSize() {
    const cv = $("m-map");
    return { W: cv.clientWidth, H: cv.clientHeight, cw: cv.clientWidth / M.map.cols, ch: cv.clientHeight / M.map.rows };
  }
  function toCanvas(r, c) {
    const g = mapSize();
    return [(c + 0.5) * g.cw, g.H - (r + 0.5) * g.ch];
  }
  function toLattice(x, y) {
    const g = mapSize();
    const c = Math.max(0, Math.min(M.map.cols - 1, x / g.cw - 0.5));
    const r = Math.max(0, Math.min(M.map.rows - 1, (g.H - y) / g.ch - 0.5));
    return [r, c];
  }

  function hidpi(cv) {  // the canvas at the screen's pixel density, drawn in CSS pixels
    const dpr = window.devicePixelRatio || 1;
    cv.width = Math.round(cv.clientWidth * dpr);
    cv.height = Math.round(cv.clientHeight * dpr);
    const ctx = cv.getContext("2d");
    ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
    return ctx;
  }

  function drawMapBase() {
    const cv = $("m-map");
    const ctx = hidpi(cv);
    const d = M.map, g = mapSize();
    for (let r = 0; r < d.rows; r++) {
      for (let c = 0; c < d.cols; c++) {
        const u = d.umatrix[r * d.cols + c];
        const grey = 250 - 170 * u;
        const pc = colorOf(d.regions[r * d.cols + c]);
        const mix = (a) => Math.round(0.62 * grey + 0.38 * a);
        ctx.fillStyle = `rgb(${mix(pc[0])},${mix(pc[1])},${mix(pc[2])})`;
        const [x, y] = toCanvas(r, c);
        ctx.fillRect(x - g.cw / 2, y - g.ch / 2, g.cw + 0.5, g.ch + 0.5);
      }
    }
    ctx.lineWidth = 1;
    for (const t of d.trajectories) {
      ctx.strokeStyle = "rgba(20,20,20,0.45)";
      ctx.beginPath();
      t.points.forEach((p, i) => { const [x, y] = toCanvas(p[0], p[1]); if (i) ctx.lineTo(x, y); else ctx.moveTo(x, y); });
      ctx.stroke();
    }
    ctx.font = "11px system-ui, sans-serif";
    ctx.textAlign = "center";
    d.centers.forEach((p, i) => {
      const [x, y] = toCanvas(p[0], p[1]);
      const c = colorOf(i);
      ctx.fillStyle = `rgb(${c[0]},${c[1]},${c[2]})`;
      ctx.strokeStyle = "#111";
      ctx.beginPath(); ctx.arc(x, y, 7, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
      ctx.fillStyle = "#fff";
      ctx.fillText(String(i), x, y + 4);
    });
    M.mapImage = ctx.getImageData(0, 0, cv.width, cv.height);
    drawMapOverlay();
  }

  function drawMapOverlay() {  // clicked points, the motion's path and its current frame
    if (!M.map || !M.mapImage) return;
    const cv = $("m-map");
    const ctx = cv.getContext("2d");
    ctx.putImageData(M.mapImage, 0, 0);
    const m = M.motion;
    if (m) {
      ctx.strokeStyle = "rgba(0,170,200,0.95)";
      ctx.lineWidth = 2.5;
      ctx.beginPath();
      m.traj.forEach((p, i) => { const [x, y] = toCanvas(p[0], p[1]); if (i) ctx.lineTo(x, y); else ctx.moveTo(x, y); });
      ctx.stroke();
      if (m.kind !== "points") {
        ctx.fillStyle = "rgba(200,30,30,0.9)";
        for (const p of m.knots) { const [x, y] = toCanvas(p[0], p[1]); ctx.fillRect(x - 4, y - 4, 8, 8); }
      }
      if ($("m-poses").checked) drawPathPoses(ctx, m);
      else M.overlay = { figures: [] };
      const f = manifoldFrame();
      const [x, y] = toCanvas(m.traj[f][0], m.traj[f][1]);
      ctx.fillStyle = "#0a6";
      ctx.beginPath(); ctx.arc(x, y, 5, 0, 2 * Math.PI); ctx.fill();
    }
    M.points.forEach((p, i) => {
      const [x, y] = toCanvas(p[0], p[1]);
      ctx.fillStyle = i === M.points.length - 1 ? "#d62728" : "#1f4fb4";
      ctx.beginPath(); ctx.arc(x, y, 5, 0, 2 * Math.PI); ctx.fill();
    });
  }

  function drawTransitions() {
    const cv = $("m-trans");
    const ctx = hidpi(cv);
    const W = cv.clientWidth, H = cv.clientHeight, L = 22, T = 22;
    const k = M.map.k, P = M.map.P;
    const cw = (W - L) / k, ch = (H - T) / k;
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, W, H);
    ctx.font = "10px system-ui, sans-serif";
    ctx.textAlign = "center";
    for (let i = 0; i < k; i++) {
      const c = colorOf(i);
      ctx.fillStyle = `rgb(${c[0]},${c[1]},${c[2]})`;
      ctx.fillText(String(i), L + (i + 0.5) * cw, 14);
      ctx.fillText(String(i), 10, T + (i + 0.5) * ch + 4);
      for (let j = 0; j < k; j++) {
        const v = Math.sqrt(P[i][j]);  // square root: the small off-diagonal entries show
        const g = Math.round(255 * (1 - v));
        ctx.fillStyle = `rgb(${g},${g},${g})`;
        ctx.fillRect(L + j * cw, T + i * ch, cw + 0.5, ch + 0.5);
      }
    }
  }

  // ---------- the paper's figures: small stick figures on the map (Fig. 4), the key-pose column
  // (Figs. 2 (b) and 5), the pose strip over the primitive memberships (Figs. 6 and 7) ----------
  //
  // A small figure is an orthographic side view (the yaw of the manifold figure's camera) of one
  // pose, its root's horizontal position taken off: u = x cos(yaw) - z sin(yaw), v = y.

  function miniProject(pos, base, nPoints, yaw) {
    const c = Math.cos(yaw), s = Math.sin(yaw);
    const rx = pos[base], rz = pos[base + 2];
    const out = new Array(nPoints);
    for (let k = 0; k < nPoints; k++) {
      const i = base + 3 * k;
      out[k] = [(pos[i] - rx) * c - (pos[i + 2] - rz) * s, pos[i + 1]];
    }
    return out;
  }

  // draw projected points pts (from miniProject) with the root at (x, y), scale px per unit;
  // returns the pixel box of the figure
  function drawMini(ctx, pts, parents, x, y, scale, rgb, width) {
    const rootV = pts[0][1];
    const at = (k) => [x + scale * pts[k][0], y - scale * (pts[k][1] - rootV)];
    const box = [Infinity, Infinity, -Infinity, -Infinity];
    ctx.lineCap = "round";
    for (const pass of [0, 1]) {  // a white halo, then the figure
      ctx.strokeStyle = pass ? `rgb(${rgb[0]},${rgb[1]},${rgb[2]})` : "rgba(255,255,255,0.85)";
      ctx.lineWidth = pass ? width : width + 2;
      ctx.beginPath();
      for (let k = 1; k < pts.length; k++) {
        if (parents[k] < 0) continue;
        const a = at(parents[k]), b = at(k);
        ctx.moveTo(a[0], a[1]);
        ctx.lineTo(b[0], b[1]);
        if (pass) {
          box[0] = Math.min(box[0], a[0], b[0]); box[1] = Math.min(box[1], a[1], b[1]);
          box[2] = Math.max(box[2], a[0], b[0]); box[3] = Math.max(box[3], a[1], b[1]);
        }
      }
      ctx.stroke();
    }
    return box;
  }

  // Fig. 4: the poses at the knots (red: the last, blue: the earlier ones) and in between (cyan)
  function drawPathPoses(ctx, m) {
    const n = m.frames, g = mapSize();
    const knotFrames = m.knotTimes.map((t) => Math.max(0, Math.min(n - 1, Math.round(t))));
    const frames = new Map();
    knotFrames.forEach((f, i) => frames.set(f, i === knotFrames.length - 1 ? "last" : "knot"));
    const gap = Math.max(1, Math.round((n - 1) / 8));  // about 8 poses in between
    for (let f = 0; f < n; f += gap) {
      if (!knotFrames.some((q) => Math.abs(q - f) < gap / 2)) frames.set(f, "between");
    }
    const hue = { last: [214, 39, 40], knot: [31, 79, 180], between: [0, 160, 190] };
    const size = Math.max(20, Math.min(48, 1.6 * Math.min(g.cw, g.ch)));
    const scale = size / m.sk.height;
    const figures = [];
    const order = [...frames.entries()].sort((a, b) => (a[1] === "between") - (b[1] === "between") || a[0] - b[0]).reverse();
    for (const [f, kind] of order) {  // knots drawn last, on top
      const [x, y] = toCanvas(m.traj[f][0], m.traj[f][1]);
      const pts = miniProject(m.pos, f * m.nPoints * 3, m.nPoints, M.cam.yaw);
      const box = drawMini(ctx, pts, m.sk.parents, x, y, scale, hue[kind], kind === "between" ? 1.5 : 2);
      figures.push({ frame: f, kind, x, y, box });
    }
    M.overlay = { figures: figures.sort((a, b) => a.frame - b.frame), size };
  }

  // Figs. 2 (b) and 5: a column of the primitives' key poses, the current one framed
  function drawKeyColumn(highlight) {
    const d = M.map, cv = $("m-keyposes");
    const k = d.k, np = d.n_points;
    const cell = Math.max(56, Math.min(100, Math.floor(440 / k)));  // about the map's height
    cv.style.height = `${k * cell + 2}px`;  // and the 1 px border (box-sizing: border-box)
    const ctx = hidpi(cv);
    const W = cv.clientWidth;
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, W, k * cell);
    const scale = (0.78 * cell) / d.height;
    const cells = [];
    ctx.font = "11px system-ui, sans-serif";
    ctx.textAlign = "left";
    for (let j = 0; j < k; j++) {
      const pts = miniProject(M.keyPoses, j * np * 3, np, M.cam.yaw);
      let lo = Infinity, hi = -Infinity;
      for (const p of pts) { lo = Math.min(lo, p[1]); hi = Math.max(hi, p[1]); }
      const top = j * cell, rgb = colorOf(j);
      // the root placed so that the pose's vertical extent is centred in its cell
      const y = top + cell / 2 + scale * ((hi + lo) / 2 - pts[0][1]);
      ctx.fillStyle = `rgb(${rgb[0]},${rgb[1]},${rgb[2]})`;
      ctx.fillRect(2, top + 4, 16, 14);
      ctx.fillStyle = "#222";
      ctx.fillText(String(j), 22, top + 15);
      const box = drawMini(ctx, pts, d.parents, W / 2 + 10, y, scale, rgb, 2);
      if (j === highlight) {
        ctx.strokeStyle = "#111";
        ctx.lineWidth = 2;
        ctx.strokeRect(1, top + 1, W - 2, cell - 2);
      }
      cells.push({ top, bottom: top + cell, box });
    }
    M.column = { count: k, cell, cells, highlight };
  }

  // Figs. 6 and 7: every step-th frame as a small figure (coloured by its primitive), over a
  // bar of each frame's fuzzy memberships (stacked, primitive 0 on top) and a row of the
  // primitive of the largest membership
  function drawStrip() {
    const m = M.motion;
    if (!m) return;
    $("m-strip-box").hidden = false;
    const cv = $("m-strip");
    cv.getContext("2d", { willReadFrequently: true });  // its image is read back once per motion
    const ctx = hidpi(cv);
    const W = cv.clientWidth, H = cv.clientHeight;
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, W, H);
    const L = 8, R = 8, figH = 92, barTop = 116, barH = 28, rowTop = barTop + barH + 2, rowH = 8;
    const n = m.frames, k = m.k;
    // at most 20 figures, as the paper's strips (80 frames: 1, 5, 9, ..., 77), and 34 px each
    const most = Math.max(2, Math.min(20, Math.floor((W - L - R) / 34)));
    const step = Math.max(1, Math.ceil(n / most));
    const fx = (f) => L + ((f + 0.5) * (W - L - R)) / n;  // frame f's column of the bar
    const scale = (0.8 * figH) / m.sk.height;
    const figures = [];
    ctx.font = "10px system-ui, sans-serif";
    ctx.textAlign = "center";
    for (let f = 0; f < n; f += step) {
      const pts = miniProject(m.pos, f * m.nPoints * 3, m.nPoints, M.cam.yaw);
      let lo = Infinity;
      for (const p of pts) lo = Math.min(lo, p[1]);
      const x = L + (figures.length + 0.5) * ((W - L - R) / Math.ceil(n / step));
      const y = 12 + figH - scale * (pts[0][1] - lo);  // feet on a common line
      const rgb = colorOf(m.membership[f]);
      const box = drawMini(ctx, pts, m.sk.parents, x, y, scale, rgb, 1.6);
      ctx.fillStyle = "#444";
      ctx.fillText(String(f + 1), x, 10);
      ctx.strokeStyle = "rgba(0,0,0,0.25)";
      ctx.lineWidth = 1;
      ctx.beginPath(); ctx.moveTo(x, 12 + figH + 2); ctx.lineTo(fx(f), barTop); ctx.stroke();
      figures.push({ frame: f, x, box, primitive: m.membership[f] });
    }
    const cw = (W - L - R) / n;
    for (let f = 0; f < n; f++) {
      let y = barTop;
      for (let j = 0; j < k; j++) {
        const u = m.memberships[f * k + j];
        if (u <= 0) continue;
        const c = colorOf(j);
        ctx.fillStyle = `rgb(${c[0]},${c[1]},${c[2]})`;
        ctx.fillRect(L + f * cw, y, cw + 0.5, u * barH);
        y += u * barH;
      }
      const c = colorOf(m.membership[f]);
      ctx.fillStyle = `rgb(${c[0]},${c[1]},${c[2]})`;
      ctx.fillRect(L + f * cw, rowTop, cw + 0.5, rowH);
    }
    M.stripImage = ctx.getImageData(0, 0, cv.width, cv.height);
    M.strip = { step, figures, L, R, barTop, barH, rowTop, rowH, width: W, marker: -1 };
    const used = [...new Set(m.membership)].sort((a, b) => a - b);
    $("m-strip-note").textContent = `frames ${figures.map((q) => q.frame + 1).slice(0, 4).join(", ")}, … (every ${step}. frame); ` +
      `bar: each frame's fuzzy membership in the primitives (m = 2), the row under it the largest; primitives met: ${used.join(", ")}`;
  }

  function drawStripMarker(f) {
    if (!M.strip || !M.stripImage || M.strip.marker === f) return;
    const cv = $("m-strip");
    const ctx = cv.getContext("2d");
    ctx.putImageData(M.stripImage, 0, 0);
    const s = M.strip, n = M.motion.frames;
    const x = s.L + ((f + 0.5) * (s.width - s.L - s.R)) / n;
    ctx.strokeStyle = "#0a6";
    ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(x, s.barTop - 4); ctx.lineTo(x, s.rowTop + s.rowH + 4); ctx.stroke();
    s.marker = f;
  }

  function manifoldFrame() {
    const m = M.motion;
    return m ? Math.min(m.frames - 1, Math.max(0, Math.floor(M.t * m.fps + 1e-6))) : 0;
  }

  function manifoldTick(dt) {
    const m = M.motion;
    if (!m) return;
    if (M.playing) {
      M.t += dt;
      if (M.t * m.fps > m.frames - 1 + 1e-6) M.t = 0;
    }
    const cv = $("m-figure");
    const dpr = window.devicePixelRatio || 1;
    const w = Math.round(cv.clientWidth * dpr);
    if (cv.width !== w || cv.height !== w) { cv.width = w; cv.height = w; }
    const ctx = cv.getContext("2d");
    ctx.fillStyle = "#fff";
    ctx.fillRect(0, 0, cv.width, cv.height);
    const f = manifoldFrame();
    const root = point(m, f, 0, [0, 0, 0]);
    const want = [root[0], m.sk.floor + 0.5 * m.sk.height, root[2]];
    if (!M.target) M.target = want;
    else for (let a = 0; a < 3; a++) M.target[a] += 0.15 * (want[a] - M.target[a]);
    const cam = camera(M.target, cv.width, cv.height, m.sk.height, M.cam);
    drawGrid(ctx, cam, M.target, m.sk);
    drawFigure(ctx, cam, m, f, [0, 0, 0], false, null);
    $("m-time").textContent = `${f + 1} / ${m.frames} · ${(f / m.fps).toFixed(2)} s`;
    M.drawn = { frame: f, positions: Array.from({ length: m.sk.nJoints }, (_, k) => point(m, f, k, [0, 0, 0])) };
    drawMapOverlay();
    if (M.column && M.column.highlight !== m.membership[f]) drawKeyColumn(m.membership[f]);
    drawStripMarker(f);
  }

  window.addEventListener("resize", () => { if (S.proc) drawChart(); });

  window.mlayerViewer = {
    state: S, play, pause, setFrame, request,
    get ready() { return S.ready; },
    get drawn() { return S.drawn; },
    manifold: { state: M, train: manifoldTrain, request: manifoldRequest, toLattice, toCanvas, colorOf,
      pause: () => { M.playing = false; $("m-play").textContent = "play"; },
      setFrame: (f) => { if (M.motion) M.t = Math.max(0, Math.min(M.motion.frames - 1, f)) / M.motion.fps; },
      get drawn() { return M.drawn; } },
  };
  document.addEventListener("DOMContentLoaded", start);
})();
