// slamkit replay: plays back a run recorded by `slamkit run --replay`. The recording (see
// pipeline/replay.hpp) sits in the page as JSON; this script draws one frame at a time: the true
// and estimated paths, the map with 2-sigma covariance ellipses, the scan's observations as rays
// coloured by what the filter did with each, particles, and in sync the pose error with its 2-sigma
// band and the landmark standard deviations over time (the tutorial's Figure 3). For a grid filter,
// the occupancy grid of its best particle as it grows and where the scan's beams end. The map has a grid
// in metres and a scale bar that follow zoom, and fills what the window leaves it; every canvas is
// drawn at the screen's pixel ratio. window.replay exposes the state and what the last frame drew,
// for the browser test.
(function () {
  'use strict';

  const data = JSON.parse(document.getElementById('replay-data').textContent);
  const frames = data.frames;
  const decisions = ['update', 'new', 'discard', 'wrong', 'pending'];
  const colours = { update: '#16a34a', new: '#2563eb', discard: '#9ca3af', wrong: '#dc2626', pending: '#d97706' };
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
  const gridRun = frames.some((f) => f.beam_ends !== undefined);

  // A grid filter's map is pictured in some frames; a frame shows the latest picture at or before it.
  // Pictures are decoded when first shown, and the map is drawn again once one has loaded.
  const pictureFrame = [];
  frames.forEach((f, i) => pictureFrame.push(f.grid ? i : (i ? pictureFrame[i - 1] : -1)));
  const pictures = new Map();
  function picture(frameIndex) {
    const k = pictureFrame[frameIndex];
    if (k === undefined || k < 0) return null;
    if (!pictures.has(k)) {
      const image = new Image();
      image.onload = () => redrawSoon();
      image.src = `data:image/png;base64,${frames[k].grid.png}`;
      pictures.set(k, image);
    }
    return { frame: k, image: pictures.get(k), box: frames[k].grid };
  }

  // A canvas's pixels follow its box on screen and the screen's pixel ratio, so that lines stay
  // sharp on high-DPI screens; drawing is in CSS pixels.
  function prepare(canvas) {
    const ratio = window.devicePixelRatio || 1;
    const w = Math.max(1, canvas.clientWidth), h = Math.max(1, canvas.clientHeight);
    const pw = Math.round(w * ratio), ph = Math.round(h * ratio);
    if (canvas.width !== pw || canvas.height !== ph) { canvas.width = pw; canvas.height = ph; }
    const ctx = canvas.getContext('2d');
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    return { ctx, w, h, ratio };
  }

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
    const map = frames.length ? frames[frames.length - 1].grid : null;
    if (map) { add(map.x, map.y); add(map.x + map.w, map.y + map.h); }
    if (!isFinite(b.minX)) { b.minX = -1; b.maxX = 1; b.minY = -1; b.maxY = 1; }
    return b;
  }

  // scale: CSS pixels per metre. A fitted view is fitted again when the map's box changes; once the
  // user zooms or pans, resizing keeps the centre and the scale.
  const view = { scale: 1, cx: 0, cy: 0, fitted: true };
  const mapSize = { w: 1, h: 1 };
  function fitView() {
    const b = worldBounds();
    const margin = 1.1;
    view.cx = (b.minX + b.maxX) / 2;
    view.cy = (b.minY + b.maxY) / 2;
    view.scale = Math.min(mapSize.w / ((b.maxX - b.minX) * margin || 1),
                          mapSize.h / ((b.maxY - b.minY) * margin || 1));
    view.fitted = true;
  }
  const toScreen = (x, y) => [mapSize.w / 2 + (x - view.cx) * view.scale,
                              mapSize.h / 2 - (y - view.cy) * view.scale];
  const toWorld = (sx, sy) => [view.cx + (sx - mapSize.w / 2) / view.scale, view.cy - (sy - mapSize.h / 2) / view.scale];

  // ---- grid and scale bar: round steps of 1, 2 or 5 x 10^k metres, chosen for the current zoom.
  function roundStep(atLeast) {
    const power = 10 ** Math.floor(Math.log10(atLeast));
    return [1, 2, 5, 10].map((m) => m * power).find((v) => v >= atLeast * (1 - 1e-9));
  }
  const metres = (v, step) => `${v.toFixed(Math.max(0, -Math.floor(Math.log10(step) + 1e-9)))} m`;

  function gridLines(w, h) {
    const step = roundStep(90 / view.scale); // a line about every 90 px or more
    const [x0, y1] = toWorld(0, 0), [x1, y0] = toWorld(w, h);
    const ticks = (lo, hi) => {
      const out = [];
      for (let k = Math.ceil(lo / step); k * step <= hi; ++k) out.push(k * step);
      return out;
    };
    return { step, x: ticks(x0, x1), y: ticks(y0, y1) };
  }

  function drawGrid(ctx, grid, w, h) {
    ctx.strokeStyle = '#eceef1'; ctx.lineWidth = 1;
    ctx.beginPath();
    grid.x.forEach((x) => { const sx = Math.round(toScreen(x, 0)[0]) + 0.5; ctx.moveTo(sx, 0); ctx.lineTo(sx, h); });
    grid.y.forEach((y) => { const sy = Math.round(toScreen(0, y)[1]) + 0.5; ctx.moveTo(0, sy); ctx.lineTo(w, sy); });
    ctx.stroke();
  }

  // Labels on top of the data, along the bottom (x) and left (y) edges, each on a white patch.
  function drawAxisLabels(ctx, grid, w, h) {
    ctx.font = '11px sans-serif'; ctx.textBaseline = 'middle';
    const labelAt = (text, x, y, align) => {
      const width = ctx.measureText(text).width;
      const left = align === 'center' ? x - width / 2 : x;
      ctx.fillStyle = 'rgba(255, 255, 255, 0.85)'; ctx.fillRect(left - 2, y - 7, width + 4, 14);
      ctx.fillStyle = '#4b5563'; ctx.textAlign = align; ctx.fillText(text, x, y);
    };
    grid.x.forEach((x) => labelAt(metres(x, grid.step), toScreen(x, 0)[0], h - 10, 'center'));
    grid.y.forEach((y) => { const sy = toScreen(0, y)[1]; if (sy < h - 24) labelAt(metres(y, grid.step), 4, sy, 'left'); });
    ctx.textAlign = 'left';
  }

  function drawScaleBar(ctx, w, h) {
    const length = roundStep(80 / view.scale), pixels = length * view.scale;
    const x1 = w - 14, x0 = x1 - pixels, y = h - 28;
    ctx.fillStyle = 'rgba(255, 255, 255, 0.85)'; ctx.fillRect(x0 - 6, y - 18, pixels + 12, 26);
    ctx.strokeStyle = '#111827'; ctx.lineWidth = 2;
    ctx.beginPath(); ctx.moveTo(x0, y - 4); ctx.lineTo(x0, y); ctx.lineTo(x1, y); ctx.lineTo(x1, y - 4); ctx.stroke();
    ctx.fillStyle = '#111827'; ctx.font = '11px sans-serif'; ctx.textAlign = 'center'; ctx.textBaseline = 'alphabetic';
    ctx.fillText(metres(length, length), (x0 + x1) / 2, y - 7);
    ctx.textAlign = 'left';
    return { metres: length, pixels };
  }

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
    const { ctx, w, h, ratio } = prepare(mapCanvas);
    const resized = w !== mapSize.w || h !== mapSize.h;
    mapSize.w = w; mapSize.h = h;
    if (resized && view.fitted) fitView();
    const drawn = { frame: state.frame, landmarks: 0, hypotheses: 0, particles: 0, beamEnds: 0, occupancy: null,
                    rays: { update: 0, new: 0, discard: 0, wrong: 0, pending: 0 },
                    size: { w, h, ratio, pixelWidth: mapCanvas.width, pixelHeight: mapCanvas.height } };
    ctx.fillStyle = '#ffffff';
    ctx.fillRect(0, 0, w, h);
    const grid = gridLines(w, h);
    drawGrid(ctx, grid, w, h);

    // The occupancy grid under everything else, each cell a crisp square at any zoom.
    const shown = picture(state.frame);
    if (shown && shown.image.complete && shown.image.naturalWidth > 0) {
      const [sx, sy] = toScreen(shown.box.x, shown.box.y + shown.box.h);
      ctx.imageSmoothingEnabled = false;
      ctx.drawImage(shown.image, sx, sy, shown.box.w * view.scale, shown.box.h * view.scale);
      drawn.occupancy = { frame: shown.frame, width: shown.image.naturalWidth, height: shown.image.naturalHeight };
    }

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
    // Where the laser's beams ended, as the filter placed the scan.
    const ends = f.beam_ends || [];
    ctx.fillStyle = '#0891b2';
    for (let i = 0; i < ends.length; i += 2) {
      const [sx, sy] = toScreen(ends[i], ends[i + 1]);
      ctx.fillRect(Math.round(sx) - 1, Math.round(sy) - 1, 2, 2);
      drawn.beamEnds += 1;
    }
    // A range alone puts its landmark on a circle about the sensor.
    const rings = f.rings || [];
    for (let i = 0; i < rings.length; i += 4) {
      const name = decisions[rings[i + 3]];
      const [cx, cy] = toScreen(rings[i], rings[i + 1]);
      ctx.strokeStyle = colours[name]; ctx.lineWidth = name === 'wrong' ? 2 : 1;
      ctx.beginPath(); ctx.arc(cx, cy, rings[i + 2] * view.scale, 0, 2 * Math.PI); ctx.stroke();
      drawn.rays[name] += 1;
    }

    // Where the landmarks waiting to start may lie (a range's ring of hypotheses, a mirror image),
    // in the pending colour: 2-sigma ellipses, the likelier the bolder.
    const hypotheses = f.hypotheses || [];
    ctx.strokeStyle = colours.pending; ctx.fillStyle = colours.pending; ctx.lineWidth = 1;
    for (let i = 0; i < hypotheses.length; i += 7) {
      const [x, y] = [hypotheses[i + 1], hypotheses[i + 2]];
      const [sx, sy] = toScreen(x, y);
      ctx.globalAlpha = 0.3 + 0.7 * hypotheses[i + 6];
      ctx.fillRect(sx - 1, sy - 1, 2, 2);
      ellipse(ctx, x, y, hypotheses[i + 3], hypotheses[i + 4], hypotheses[i + 5]);
      drawn.hypotheses += 1;
    }
    ctx.globalAlpha = 1;

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

    drawAxisLabels(ctx, grid, w, h);
    drawn.grid = grid;
    drawn.scaleBar = drawScaleBar(ctx, w, h);
    return drawn;
  }

  // ---- the time panels, each with a cursor at the current frame
  function panel(canvas, series, title, current) {
    const { ctx, w, h } = prepare(canvas);
    const left = 48, bottom = 18, top = 16;
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
  // Unaligned where the truth shares the map's frame (recordings before "error_aligned" aligned
  // exactly the truths without headings).
  const errorAligned = data.meta.error_aligned ?? !data.meta.truth_has_headings;
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
    panel(errorCanvas, errorSeries,
          errorSeries.length ? `pose error [m], ${errorAligned ? 'aligned' : 'unaligned'}: x (blue), y (green)`
                             : 'pose error: no ground truth for this dataset', f.t);
    panel(stdCanvas, stdSeries, gridRun ? 'landmark std: none, this filter maps an occupancy grid'
                                        : 'landmark std x [m] (first six landmarks)', f.t);
    slider.value = String(state.frame);
    label.textContent = `t = ${f.t.toFixed(1)} s, frame ${state.frame + 1}/${frames.length}, ` +
      (gridRun ? 'occupancy grid of the best particle' : `${f.landmarks.length / 6} landmarks`);
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
    const [wx, wy] = toWorld(e.offsetX, e.offsetY);
    view.scale *= Math.exp(-e.deltaY * 0.001);
    view.cx = wx - (e.offsetX - mapSize.w / 2) / view.scale;
    view.cy = wy + (e.offsetY - mapSize.h / 2) / view.scale;
    view.fitted = false;
    draw();
  }, { passive: false });
  let dragFrom = null;
  mapCanvas.addEventListener('mousedown', (e) => { dragFrom = [e.clientX, e.clientY]; });
  window.addEventListener('mouseup', () => { dragFrom = null; });
  window.addEventListener('mousemove', (e) => {
    if (!dragFrom) return;
    view.cx -= (e.clientX - dragFrom[0]) / view.scale;
    view.cy += (e.clientY - dragFrom[1]) / view.scale;
    view.fitted = false;
    dragFrom = [e.clientX, e.clientY];
    draw();
  });
  mapCanvas.addEventListener('dblclick', () => { fitView(); draw(); });
  // A new window size or pixel ratio is drawn once, at the next frame.
  let redrawQueued = false;
  const redrawSoon = () => {
    if (redrawQueued) return;
    redrawQueued = true;
    requestAnimationFrame(() => { redrawQueued = false; draw(); });
  };
  window.addEventListener('resize', redrawSoon);
  new ResizeObserver(redrawSoon).observe(mapCanvas);

  document.getElementById('meta').textContent =
    `${data.meta.filter} on ${data.meta.dataset}: ${frames.length} frames, ${data.meta.decimation}`;
  document.getElementById('wrong-note').textContent = data.meta.wrong_known
    ? 'wrong: updated a landmark started by another true landmark'
    : 'wrong: not known (the truth does not name each observation\'s landmark)';
  document.getElementById('error-note').textContent = !errorSeries.length ? '' : errorAligned
    ? 'Pose error after the evaluation\'s SE(2) alignment of the whole run onto the truth, whose frame is its own ' +
      '(GPS); the bands are the filter\'s own 2-sigma.'
    : 'Pose error unaligned: estimate minus truth in the map frame, which is the truth\'s start pose (as for pose ' +
      'NEES), so it includes the drift that the ATE\'s SE(2) alignment removes; the bands are the filter\'s own 2-sigma.';
  slider.max = String(Math.max(0, frames.length - 1));
  mapSize.w = Math.max(1, mapCanvas.clientWidth); mapSize.h = Math.max(1, mapCanvas.clientHeight);
  fitView();
  seek(0);

  window.replay = {
    data, play, pause, seek,
    get frame() { return state.frame; },
    get playing() { return state.playing; },
    get drawn() { return state.drawn; },
    zoom(factor) { view.scale *= factor; view.fitted = false; draw(); },
    get scale() { return view.scale; },
    get view() { return { ...view, width: mapSize.w, height: mapSize.h }; },
    errorAligned,
  };
})();
