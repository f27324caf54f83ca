// slamkit replay: plays back a run recorded by `slamkit run --replay`. The recording (see
// pipeline/replay.hpp) sits in the page as JSON; this script draws one frame at a time: the true
// and estimated paths, the map with 2-sigma covariance ellipses, the scan's observations as rays
// coloured by what the filter did with each, particles, and in sync the pose error with its 2-sigma
// band and the landmark standard deviations over time (the tutorial's Figure 3).
// window.replay exposes the state and what the last frame drew, for the browser test.
(function () {
  'use strict';

  const data = JSON.parse(document.getElementById('replay-data').textContent);
  const frames = data.frames;
  const decisions = ['update', 'new', 'discard', 'wrong'];
  const colours = { update: '#16a34a', new: '#2563eb', discard: '#9ca3af', wrong: '#dc2626' };
  const sigmaScale = 2; // ellipses and bands at two standard deviations
  const baseFramesPerSecond = 20;

  const mapCanvas = document.getElementById('map');
  const errorCanvas = document.getElementById('error');
  const stdCanvas = document.getElementById('std');
  const slider = document.getElementById('time');
  const playButton = document.getElementById('play');
  const speedSelect = document.getElementById('speed');
  const label = document.getElementById('label');

  const state = { frame: 0, playing: false, drawn: null };

  // ---- world to screen: fitted to everything the run visits, then zoomed and panned by the user.
  function worldBounds() {
    const b = { minX: Infinity, maxX: -Infinity, minY: Infinity, maxY: -Infinity };
    const add = (x, y) => {
      b.minX = Math.min(b.minX, x); b.maxX = Math.max(b.maxX, x);
      b.minY = Math.min(b.minY, y); b.maxY = Math.max(b.maxY, y);
    };
    data.truth.forEach((p) => add(p[1], p[2]));
    data.true_landmarks.forEach((p) => add(p[0], p[1]));
    frames.forEach((f) => add(f.pose[0], f.pose[1]));
    const last = frames.length ? frames[frames.length - 1].landmarks : [];
    for (let i = 0; i < last.length; i += 6) add(last[i + 1], last[i + 2]);
    if (!isFinite(b.minX)) { b.minX = -1; b.maxX = 1; b.minY = -1; b.maxY = 1; }
    return b;
  }

  const view = { scale: 1, cx: 0, cy: 0 };
  function fitView() {
    const b = worldBounds();
    const margin = 1.1;
    view.cx = (b.minX + b.maxX) / 2;
    view.cy = (b.minY + b.maxY) / 2;
    view.scale = Math.min(mapCanvas.width / ((b.maxX - b.minX) * margin || 1),
                          mapCanvas.height / ((b.maxY - b.minY) * margin || 1));
  }
  const toScreen = (x, y) => [mapCanvas.width / 2 + (x - view.cx) * view.scale,
                              mapCanvas.height / 2 - (y - view.cy) * view.scale];

  // ---- the map
  function line(ctx, points, colour, width) {
    if (points.length < 2) return;
    ctx.strokeStyle = colour; ctx.lineWidth = width;
    ctx.beginPath();
    points.forEach(([x, y], i) => { const [sx, sy] = toScreen(x, y); if (i) ctx.lineTo(sx, sy); else ctx.moveTo(sx, sy); });
    ctx.stroke();
  }

  // The k-sigma ellipse of a 2x2 covariance, from its eigenvalues and the major axis' angle.
  function ellipse(ctx, x, y, cxx, cxy, cyy) {
    const half = (cxx + cyy) / 2;
    const root = Math.sqrt(Math.max(0, ((cxx - cyy) / 2) ** 2 + cxy * cxy));
    const major = sigmaScale * Math.sqrt(Math.max(0, half + root)) * view.scale;
    const minor = sigmaScale * Math.sqrt(Math.max(0, half - root)) * view.scale;
    const angle = 0.5 * Math.atan2(2 * cxy, cxx - cyy);
    const [sx, sy] = toScreen(x, y);
    ctx.beginPath();
    ctx.ellipse(sx, sy, Math.max(major, 0.5), Math.max(minor, 0.5), -angle, 0, 2 * Math.PI);
    ctx.stroke();
  }

  function drawMap(f) {
    const ctx = mapCanvas.getContext('2d');
    const drawn = { frame: state.frame, landmarks: 0, particles: 0, rays: { update: 0, new: 0, discard: 0, wrong: 0 } };
    ctx.fillStyle = '#ffffff';
    ctx.fillRect(0, 0, mapCanvas.width, mapCanvas.height);

    ctx.fillStyle = '#6b7280';
    data.true_landmarks.forEach(([x, y]) => { const [sx, sy] = toScreen(x, y); ctx.fillRect(sx - 2, sy - 2, 4, 4); });
    line(ctx, data.truth.filter((p) => p[0] <= f.t).map((p) => [p[1], p[2]]), '#9ca3af', 2);
    line(ctx, frames.slice(0, state.frame + 1).map((g) => [g.pose[0], g.pose[1]]), '#ea580c', 2);

    const [px, py] = toScreen(f.pose[0], f.pose[1]);
    for (let i = 0; i < f.rays.length; i += 3) {
      const name = decisions[f.rays[i + 2]];
      const [ex, ey] = toScreen(f.rays[i], f.rays[i + 1]);
      ctx.strokeStyle = colours[name]; ctx.lineWidth = name === 'wrong' ? 2 : 1;
      ctx.beginPath(); ctx.moveTo(px, py); ctx.lineTo(ex, ey); ctx.stroke();
      drawn.rays[name] += 1;
    }

    ctx.strokeStyle = '#1e3a8a'; ctx.fillStyle = '#1e3a8a'; ctx.lineWidth = 1;
    for (let i = 0; i < f.landmarks.length; i += 6) {
      const [x, y] = [f.landmarks[i + 1], f.landmarks[i + 2]];
      const [sx, sy] = toScreen(x, y);
      ctx.fillRect(sx - 1.5, sy - 1.5, 3, 3);
      ellipse(ctx, x, y, f.landmarks[i + 3], f.landmarks[i + 4], f.landmarks[i + 5]);
      drawn.landmarks += 1;
    }

    ctx.strokeStyle = '#ea580c'; ctx.lineWidth = 1.5;
    ellipse(ctx, f.pose[0], f.pose[1], f.cov[0], f.cov[1], f.cov[2]);
    const heading = f.pose[2];
    ctx.beginPath(); ctx.moveTo(px, py);
    ctx.lineTo(px + 14 * Math.cos(heading), py - 14 * Math.sin(heading)); ctx.stroke();
    // Particles last: they gather around the pose and would be hidden under it.
    const particles = f.particles || [];
    ctx.fillStyle = '#9333ea';
    for (let i = 0; i < particles.length; i += 2) {
      const [sx, sy] = toScreen(particles[i], particles[i + 1]);
      ctx.fillRect(Math.round(sx) - 1, Math.round(sy) - 1, 2, 2); // whole pixels: crisp, not blurred
      drawn.particles += 1;
    }

    return drawn;
  }

  // ---- the time panels, each with a cursor at the current frame
  function panel(canvas, series, title, current) {
    const ctx = canvas.getContext('2d');
    const w = canvas.width, h = canvas.height, left = 48, bottom = 18, top = 16;
    ctx.fillStyle = '#ffffff'; ctx.fillRect(0, 0, w, h);
    ctx.fillStyle = '#111827'; ctx.font = '12px sans-serif'; ctx.fillText(title, left, 12);
    if (!frames.length) return;
    const t0 = frames[0].t, t1 = Math.max(frames[frames.length - 1].t, t0 + 1e-9);
    let lo = Infinity, hi = -Infinity;
    series.forEach((s) => s.points.forEach(([, a, b]) => { lo = Math.min(lo, a, b ?? a); hi = Math.max(hi, a, b ?? a); }));
    if (!isFinite(lo)) { lo = -1; hi = 1; }
    if (hi - lo < 1e-9) { lo -= 1; hi += 1; }
    const sx = (t) => left + (t - t0) / (t1 - t0) * (w - left - 4);
    const sy = (v) => top + (hi - v) / (hi - lo) * (h - top - bottom);
    ctx.strokeStyle = '#d1d5db'; ctx.beginPath(); ctx.moveTo(left, sy(0)); ctx.lineTo(w, sy(0)); ctx.stroke();
    ctx.fillStyle = '#6b7280';
    ctx.fillText(hi.toPrecision(2), 2, top + 8); ctx.fillText(lo.toPrecision(2), 2, h - bottom);
    ctx.fillText(`${t0.toFixed(0)} s`, left, h - 4); ctx.fillText(`${t1.toFixed(0)} s`, w - 40, h - 4);
    series.forEach((s) => {
      if (s.band) {
        ctx.fillStyle = s.colour; ctx.beginPath();
        s.points.forEach(([t, a], i) => (i ? ctx.lineTo(sx(t), sy(a)) : ctx.moveTo(sx(t), sy(a))));
        for (let i = s.points.length - 1; i >= 0; --i) ctx.lineTo(sx(s.points[i][0]), sy(s.points[i][2]));
        ctx.fill();
      } else {
        ctx.strokeStyle = s.colour; ctx.lineWidth = 1.2; ctx.beginPath();
        s.points.forEach(([t, a], i) => (i ? ctx.lineTo(sx(t), sy(a)) : ctx.moveTo(sx(t), sy(a))));
        ctx.stroke();
      }
    });
    ctx.strokeStyle = '#111827'; ctx.lineWidth = 1;
    ctx.beginPath(); ctx.moveTo(sx(current), top); ctx.lineTo(sx(current), h - bottom); ctx.stroke();
  }

  // Pose error per axis with the filter's own 2-sigma band: a consistent filter keeps the error inside.
  const errorSeries = [];
  if (frames.some((f) => f.error)) {
    const withError = frames.filter((f) => f.error);
    [['x', 0, 0, '#2563eb'], ['y', 1, 2, '#16a34a']].forEach(([, e, c, colour]) => {
      errorSeries.push({ band: true, colour: colour + '33',
                         points: withError.map((f) => [f.t, sigmaScale * Math.sqrt(f.cov[c]), -sigmaScale * Math.sqrt(f.cov[c])]) });
      errorSeries.push({ colour, points: withError.map((f) => [f.t, f.error[e]]) });
    });
  }

  // Figure 3: the x standard deviation of the first landmarks the filter mapped, over time.
  const stdSeries = (() => {
    const ids = [];
    for (const f of frames) {
      for (let i = 0; i < f.landmarks.length && ids.length < 6; i += 6) if (!ids.includes(f.landmarks[i])) ids.push(f.landmarks[i]);
      if (ids.length >= 6) break;
    }
    const palette = ['#2563eb', '#16a34a', '#dc2626', '#9333ea', '#ea580c', '#0891b2'];
    return ids.map((id, k) => ({ colour: palette[k], points: frames.flatMap((f) => {
      for (let i = 0; i < f.landmarks.length; i += 6) if (f.landmarks[i] === id) return [[f.t, Math.sqrt(Math.max(0, f.landmarks[i + 3]))]];
      return [];
    }) }));
  })();

  function draw() {
    if (!frames.length) { label.textContent = 'no scans recorded'; return; }
    const f = frames[state.frame];
    state.drawn = drawMap(f);
    panel(errorCanvas, errorSeries, errorSeries.length ? 'pose error x (blue), y (green) [m] with 2-sigma bands'
                                                       : 'pose error: no ground truth for this dataset', f.t);
    panel(stdCanvas, stdSeries, 'landmark std x [m] (first six landmarks)', f.t);
    slider.value = String(state.frame);
    label.textContent = `t = ${f.t.toFixed(1)} s, frame ${state.frame + 1}/${frames.length}, ` +
      `${f.landmarks.length / 6} landmarks`;
  }

  function seek(frame) {
    state.frame = Math.max(0, Math.min(frames.length - 1, Math.round(frame)));
    draw();
  }

  // ---- playback
  let lastTick = null, carried = 0;
  function tick(now) {
    if (!state.playing) return;
    if (lastTick !== null) {
      carried += (now - lastTick) / 1000 * baseFramesPerSecond * Number(speedSelect.value);
      const whole = Math.floor(carried);
      if (whole > 0) {
        carried -= whole;
        seek(state.frame + whole);
        if (state.frame === frames.length - 1) { pause(); return; }
      }
    }
    lastTick = now;
    requestAnimationFrame(tick);
  }
  function play() {
    if (state.playing || frames.length < 2) return;
    if (state.frame === frames.length - 1) seek(0);
    state.playing = true; lastTick = null; carried = 0;
    playButton.textContent = 'Pause';
    requestAnimationFrame(tick);
  }
  function pause() { state.playing = false; playButton.textContent = 'Play'; }

  playButton.addEventListener('click', () => (state.playing ? pause() : play()));
  slider.addEventListener('input', () => seek(Number(slider.value)));
  document.addEventListener('keydown', (e) => {
    if (e.key === ' ') { e.preventDefault(); playButton.click(); }
    if (e.key === 'ArrowRight') seek(state.frame + 1);
    if (e.key === 'ArrowLeft') seek(state.frame - 1);
  });

  // ---- zoom about the cursor with the wheel, pan by dragging, double-click to fit
  mapCanvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    const rect = mapCanvas.getBoundingClientRect();
    const mx = (e.clientX - rect.left) * mapCanvas.width / rect.width, my = (e.clientY - rect.top) * mapCanvas.height / rect.height;
    const wx = view.cx + (mx - mapCanvas.width / 2) / view.scale, wy = view.cy - (my - mapCanvas.height / 2) / view.scale;
    view.scale *= Math.exp(-e.deltaY * 0.001);
    view.cx = wx - (mx - mapCanvas.width / 2) / view.scale;
    view.cy = wy + (my - mapCanvas.height / 2) / view.scale;
    draw();
  }, { passive: false });
  let dragFrom = null;
  mapCanvas.addEventListener('mousedown', (e) => { dragFrom = [e.clientX, e.clientY]; });
  window.addEventListener('mouseup', () => { dragFrom = null; });
  window.addEventListener('mousemove', (e) => {
    if (!dragFrom) return;
    const rect = mapCanvas.getBoundingClientRect(), k = mapCanvas.width / rect.width;
    view.cx -= (e.clientX - dragFrom[0]) * k / view.scale;
    view.cy += (e.clientY - dragFrom[1]) * k / view.scale;
    dragFrom = [e.clientX, e.clientY];
    draw();
  });
  mapCanvas.addEventListener('dblclick', () => { fitView(); draw(); });

  document.getElementById('meta').textContent =
    `${data.meta.filter} on ${data.meta.dataset}: ${frames.length} frames, ${data.meta.decimation}`;
  document.getElementById('wrong-note').textContent = data.meta.wrong_known
    ? 'wrong: updated a landmark started by another true landmark'
    : 'wrong: not known (the truth does not name each observation\'s landmark)';
  slider.max = String(Math.max(0, frames.length - 1));
  fitView();
  seek(0);

  window.replay = {
    data, play, pause, seek,
    get frame() { return state.frame; },
    get playing() { return state.playing; },
    get drawn() { return state.drawn; },
    zoom(factor) { view.scale *= factor; draw(); },
    get scale() { return view.scale; },
  };
})();
