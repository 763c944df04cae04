// loopd's live page: the state loopd sends over the WebSocket /ws (src/loopd/web/view_feed.cpp), drawn as a top view
// (canvas), a 3D view (Debian's three.js), a funnel chart (Debian's Chart.js) and tables. Read-only: the page sends
// nothing loopd acts on.
'use strict';

const SESSION_COLOURS = ['#1f77b4', '#d62728', '#2ca02c', '#9467bd', '#ff7f0e', '#17becf', '#8c564b', '#e377c2'];
const STAGE_COLOURS = {
  gate: '#9aa0a6', descriptor: '#c9a227', place: '#b07cc6', fourpcs: '#e07b39', gicp: '#d9534f', degeneracy: '#8e5ea2',
  hungarian: '#3b7dd8', prior: '#7f7f7f', confirmation: '#5bc0de', session: '#bcbd22', input: '#555555', accepted: '#1d9a3a',
};
const MAX_DECISIONS = 30000;  // rejected candidates kept on the page (accepted loops are all kept)

const state = {
  source: '', keyframes: new Map(), sessions: new Map(), accepted: [], rejected: [], clouds: new Map(),
  health: {}, funnel: {}, counts: {}, verifyMs: null, revision: 0, synced: false,
};
const view = { scale: 1, cx: 0, cy: 0, fitted: false, dirty: true, dirty3d: true, selected: null };
const $ = (id) => document.getElementById(id);
const keyOf = (k) => k[0] + '/' + k[1];
const sessionColour = (s) => SESSION_COLOURS[((s % SESSION_COLOURS.length) + SESSION_COLOURS.length) % SESSION_COLOURS.length];
const stageColour = (s) => STAGE_COLOURS[s] || '#444';

// ---- the feed ------------------------------------------------------------------------------------------------------

function reset() {
  state.keyframes.clear(); state.sessions.clear(); state.accepted = []; state.rejected = []; state.clouds.clear();
  state.health = {}; state.funnel = {}; state.counts = {}; state.synced = false; view.fitted = false; view.selected = null;
}

function keyframe(s, i) {
  const key = s + '/' + i;
  let k = state.keyframes.get(key);
  if (!k) {
    k = { s: s, i: i, t: 0, odom: null, pose: null };
    state.keyframes.set(key, k);
    if (!state.sessions.has(s)) state.sessions.set(s, []);
    const list = state.sessions.get(s);
    list.push(k);
    if (list.length > 1 && list[list.length - 2].i > i) list.sort((a, b) => a.i - b.i);
  }
  return k;
}

function decodeCloud(b64) {
  const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
  const v = new DataView(bytes.buffer);
  const n = Math.floor(bytes.length / 6);
  const out = new Float32Array(n * 3);
  for (let j = 0; j < n * 3; ++j) out[j] = v.getInt16(j * 2, true) / 100;
  return out;
}

function apply(m) {
  if (m.type === 'hello') { reset(); state.source = m.source || ''; }
  for (const r of m.keyframes || []) {
    const k = keyframe(r[0], r[1]);
    k.t = r[2];
    if (r[3]) k.odom = r[3];
  }
  for (const p of m.poses || []) keyframe(p[0], p[1]).pose = [p[2], p[3], p[4], p[5]];
  for (const d of m.decisions || []) (d.a ? state.accepted : state.rejected).push(d);
  if (state.rejected.length > MAX_DECISIONS) state.rejected.splice(0, state.rejected.length - MAX_DECISIONS);
  for (const c of m.clouds || []) {
    state.clouds.set(keyOf(c.k), decodeCloud(c.p));
    while (state.clouds.size > 60) state.clouds.delete(state.clouds.keys().next().value);
  }
  if (m.health) state.health = m.health;
  if (m.funnel) state.funnel = m.funnel;
  if (m.counts) state.counts = m.counts;
  if (m.verify_ms) state.verifyMs = m.verify_ms;
  state.revision = m.revision || state.revision;
  state.synced = !m.more && Object.keys(state.health).length > 0;
  if ((m.decisions || []).length) showRecent(m.decisions);
  view.dirty = true; view.dirty3d = true;
  updatePanels();
}

function connect() {
  const ws = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/ws');
  ws.onopen = () => setConnection('live', 'live');
  ws.onmessage = (e) => { try { apply(JSON.parse(e.data)); } catch (err) { console.error(err); } };
  ws.onclose = (e) => {
    setConnection('lost', e.reason ? 'closed: ' + e.reason : 'disconnected, retrying');
    document.body.dataset.state = 'disconnected';
    setTimeout(connect, 2000);
  };
}

function setConnection(cls, text) {
  const c = $('connection');
  c.className = 'badge ' + cls;
  c.textContent = text;
}

// ---- panels --------------------------------------------------------------------------------------------------------

const fmt = (v) => (typeof v !== 'number' ? String(v) : Number.isInteger(v) ? v.toLocaleString('en') : v.toFixed(3));
function bytes(v) { return v >= 1048576 ? (v / 1048576).toFixed(1) + ' MiB' : v >= 1024 ? (v / 1024).toFixed(1) + ' KiB' : v + ' B'; }

function rows(tbody, list) {
  tbody.innerHTML = '';
  for (const [id, name, value] of list) {
    const tr = tbody.insertRow();
    tr.insertCell().textContent = name;
    const td = tr.insertCell();
    td.className = 'num';
    if (id) td.id = id;
    td.textContent = value;
  }
}

function funnelCounts() {
  const stages = Object.entries(state.funnel).filter(([s]) => s !== 'accepted').sort((a, b) => b[1] - a[1]);
  const rejected = stages.reduce((n, [, c]) => n + c, 0);
  return { stages: stages, rejected: rejected, accepted: state.funnel.accepted || 0 };
}

let funnelChart = null;
function updatePanels() {
  $('source').textContent = state.source;
  $('count-keyframes').textContent = state.keyframes.size;
  $('loops-shown').textContent = state.accepted.length;
  $('decisions-shown').textContent = state.accepted.length + state.rejected.length;
  $('revision').textContent = state.revision;
  const h = state.health;
  const f = funnelCounts();
  const list = [
    ['funnel-scans', 'scans received', h.scans_received === undefined ? '–' : fmt(h.scans_received)],
    ['funnel-keyframes', 'keyframes', fmt(h.keyframes ?? state.keyframes.size)],
    ['funnel-candidates', 'candidates decided', fmt(state.counts.decisions ?? 0)],
    ['funnel-accepted', 'accepted', fmt(f.accepted)],
    ['funnel-rejected', 'rejected', fmt(f.rejected)],
  ];
  for (const [s, n] of f.stages) list.push(['funnel-stage-' + s, '  rejected at ' + s, fmt(n)]);
  rows($('funnel').tBodies[0], list);
  const health = [];
  for (const [k, v] of Object.entries(h)) {
    if (k === 'scans_received') continue;
    health.push(['health-' + k, k.replace(/_/g, ' '), /bytes/.test(k) && typeof v === 'number' ? bytes(v) : fmt(v)]);
  }
  if (state.verifyMs) health.push(['health-verify-ms', 'verification ms p50 / p95 / p99',
    state.verifyMs.p50 + ' / ' + state.verifyMs.p95 + ' / ' + state.verifyMs.p99]);
  rows($('health').tBodies[0], health);
  if (window.Chart) {
    const labels = ['accepted'].concat(f.stages.map(([s]) => s));
    const data = [f.accepted].concat(f.stages.map(([, n]) => n));
    if (!funnelChart) {
      funnelChart = new Chart($('funnel-chart'), {
        type: 'bar', data: { labels: labels, datasets: [{ data: data, backgroundColor: labels.map(stageColour) }] },
        options: { animation: false, indexAxis: 'y', plugins: { legend: { display: false } }, scales: { x: { type: 'logarithmic' } } },
      });
    } else {
      funnelChart.data.labels = labels;
      funnelChart.data.datasets[0].data = data;
      funnelChart.data.datasets[0].backgroundColor = labels.map(stageColour);
      funnelChart.update();
    }
  }
  const b = document.body.dataset;
  b.state = state.synced ? 'synced' : 'loading';
  b.loops = state.accepted.length;
  b.keyframes = state.keyframes.size;
  b.decisions = state.accepted.length + state.rejected.length;
}

function showRecent(decisions) {
  const tbody = $('decisions').tBodies[0];
  for (const d of decisions.slice(-20)) {
    const tr = tbody.insertRow(0);
    if (d.a) tr.className = 'accepted';
    for (const v of [d.id, keyOf(d.q), keyOf(d.m), d.a ? 'accepted' : 'rejected', d.stage, d.reason]) tr.insertCell().textContent = v;
    tr.onclick = () => select(d);
  }
  while (tbody.rows.length > 20) tbody.deleteRow(-1);
}

function select(d) {
  view.selected = d;
  view.dirty = true;
  const box = $('decision');
  box.innerHTML = '';
  const t = document.createElement('table');
  const add = (k, v) => { const r = t.insertRow(); r.insertCell().textContent = k; r.insertCell().textContent = v; };
  add('event', d.id);
  add('keyframes', keyOf(d.q) + ' → ' + keyOf(d.m));
  add('result', d.a ? 'accepted' : 'rejected at ' + d.stage);
  if (d.reason) add('reason', d.reason);
  add('retrieval', d.retrieval);
  for (const [k, v] of Object.entries(d.scores || {})) if (v !== null) add(k.replace(/_/g, ' '), fmt(v));
  if (d.T_match_query) add('T_match_query x y z yaw', d.T_match_query.map((v) => v.toFixed(3)).join(' '));
  box.appendChild(t);
}

// ---- top view ------------------------------------------------------------------------------------------------------

const canvas = $('top-view');
const ctx = canvas.getContext('2d');
const poseOf = (k) => (k && (k.pose || k.odom)) || null;
const toScreen = (x, y) => [canvas.width / 2 + (x - view.cx) * view.scale, canvas.height / 2 - (y - view.cy) * view.scale];

function fit() {
  let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
  for (const k of state.keyframes.values()) {
    for (const p of [k.pose, $('show-odometry').checked ? k.odom : null]) {
      if (!p) continue;
      x0 = Math.min(x0, p[0]); x1 = Math.max(x1, p[0]); y0 = Math.min(y0, p[1]); y1 = Math.max(y1, p[1]);
    }
  }
  if (!isFinite(x0)) return;
  view.cx = (x0 + x1) / 2; view.cy = (y0 + y1) / 2;
  view.scale = 0.9 * Math.min(canvas.width / Math.max(x1 - x0, 1), canvas.height / Math.max(y1 - y0, 1));
  view.fitted = true;
}

function cloudPoints(key, k, each) {
  const pts = state.clouds.get(key);
  const p = poseOf(k);
  if (!pts || !p) return;
  const c = Math.cos(p[3]), s = Math.sin(p[3]);
  for (let j = 0; j < pts.length; j += 3) each(p[0] + c * pts[j] - s * pts[j + 1], p[1] + s * pts[j] + c * pts[j + 1], p[2] + pts[j + 2]);
}

function drawTop() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; view.fitted = false; }
  if (!view.fitted) fit();
  ctx.clearRect(0, 0, w, h);
  if ($('show-cloud').checked) {
    ctx.fillStyle = 'rgba(60, 70, 90, 0.35)';
    for (const key of state.clouds.keys()) cloudPoints(key, state.keyframes.get(key), (x, y) => { const q = toScreen(x, y); ctx.fillRect(q[0], q[1], 1.2, 1.2); });
  }
  const line = (list, get, colour, width, dash) => {
    ctx.strokeStyle = colour; ctx.lineWidth = width; ctx.setLineDash(dash);
    ctx.beginPath();
    let open = false;
    for (const k of list) {
      const p = get(k);
      if (!p) { open = false; continue; }
      const q = toScreen(p[0], p[1]);
      if (open) ctx.lineTo(q[0], q[1]); else ctx.moveTo(q[0], q[1]);
      open = true;
    }
    ctx.stroke();
    ctx.setLineDash([]);
  };
  for (const [s, list] of state.sessions) {
    if ($('show-odometry').checked) line(list, (k) => k.odom, sessionColour(s) + '66', 1, [4, 3]);
    line(list, poseOf, sessionColour(s), 2, []);
  }
  const link = (d, colour, width) => {
    const a = poseOf(state.keyframes.get(keyOf(d.q))), b = poseOf(state.keyframes.get(keyOf(d.m)));
    if (!a || !b) return;
    const p = toScreen(a[0], a[1]), q = toScreen(b[0], b[1]);
    ctx.strokeStyle = colour; ctx.lineWidth = width;
    ctx.beginPath(); ctx.moveTo(p[0], p[1]); ctx.lineTo(q[0], q[1]); ctx.stroke();
  };
  if ($('show-rejected').checked) {
    ctx.globalAlpha = 0.35;
    for (const d of state.rejected) link(d, stageColour(d.stage), 1);
    ctx.globalAlpha = 1;
  }
  for (const d of state.accepted) link(d, STAGE_COLOURS.accepted, 1.6);
  if (view.selected) link(view.selected, '#000', 3);
  const last = [...state.sessions.values()].map((l) => l[l.length - 1]).filter(Boolean);
  for (const k of last) {
    const p = poseOf(k);
    if (!p) continue;
    const q = toScreen(p[0], p[1]);
    ctx.fillStyle = sessionColour(k.s);
    ctx.beginPath(); ctx.arc(q[0], q[1], 5, 0, 2 * Math.PI); ctx.fill();
  }
  drawLegend();
}

function drawLegend() {
  const items = [...state.sessions.keys()].map((s) => ['session ' + s, sessionColour(s)]);
  items.push(['accepted loop', STAGE_COLOURS.accepted]);
  for (const s of Object.keys(state.funnel)) if (s !== 'accepted') items.push(['rejected: ' + s, stageColour(s)]);
  // Built as nodes, never as HTML: stage names come from the map, which may be someone else's file.
  const legend = $('legend');
  legend.replaceChildren(...items.map(([n, c]) => {
    const span = document.createElement('span');
    const swatch = document.createElement('i');
    swatch.style.background = c;
    span.append(swatch, n);
    return span;
  }));
}

function nearestDecision(x, y) {
  let best = null, bestD = 7;
  const consider = (d) => {
    const a = poseOf(state.keyframes.get(keyOf(d.q))), b = poseOf(state.keyframes.get(keyOf(d.m)));
    if (!a || !b) return;
    const p = toScreen(a[0], a[1]), q = toScreen(b[0], b[1]);
    const dx = q[0] - p[0], dy = q[1] - p[1];
    const t = Math.max(0, Math.min(1, ((x - p[0]) * dx + (y - p[1]) * dy) / Math.max(dx * dx + dy * dy, 1e-9)));
    const dist = Math.hypot(p[0] + t * dx - x, p[1] + t * dy - y);
    if (dist < bestD) { bestD = dist; best = d; }
  };
  state.accepted.forEach(consider);
  if (!best && $('show-rejected').checked) state.rejected.forEach(consider);
  return best;
}

let drag = null;
canvas.addEventListener('mousedown', (e) => { drag = { x: e.offsetX, y: e.offsetY, cx: view.cx, cy: view.cy, moved: false }; });
canvas.addEventListener('mousemove', (e) => {
  if (!drag) return;
  const dx = e.offsetX - drag.x, dy = e.offsetY - drag.y;
  if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
  view.cx = drag.cx - dx / view.scale; view.cy = drag.cy + dy / view.scale; view.fitted = true; view.dirty = true;
});
canvas.addEventListener('mouseup', (e) => {
  if (drag && !drag.moved) { const d = nearestDecision(e.offsetX, e.offsetY); if (d) select(d); }
  drag = null;
});
canvas.addEventListener('wheel', (e) => {
  e.preventDefault();
  view.scale *= e.deltaY < 0 ? 1.2 : 1 / 1.2; view.fitted = true; view.dirty = true;
}, { passive: false });
$('fit').onclick = () => { view.fitted = false; view.dirty = true; };
for (const id of ['show-odometry', 'show-rejected', 'show-cloud']) $(id).onchange = () => { view.dirty = true; view.dirty3d = true; };

// ---- 3D view -------------------------------------------------------------------------------------------------------

const three = { ok: false };
function init3d() {
  const box = $('view3d');
  if (!window.THREE) { $('view3d-note').textContent = '3D view: three.js is not installed (apt install libjs-three).'; return; }
  try {
    three.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  } catch (err) {
    $('view3d-note').textContent = '3D view: WebGL is not available in this browser.';
    return;
  }
  $('view3d-note').remove();
  three.renderer.setClearColor(0xffffff);
  box.appendChild(three.renderer.domElement);
  three.scene = new THREE.Scene();
  three.camera = new THREE.PerspectiveCamera(50, 1, 0.5, 20000);
  three.camera.up.set(0, 0, 1);
  three.camera.position.set(-80, -80, 80);
  if (THREE.OrbitControls) {
    three.controls = new THREE.OrbitControls(three.camera, three.renderer.domElement);
    three.controls.addEventListener('change', () => { three.needsRender = true; });
  }
  three.group = new THREE.Group();
  three.scene.add(three.group);
  three.ok = true;
}

function lineGeometry(points) {
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(points, 3));
  return g;
}

function build3d() {
  const g = three.group;
  for (const o of [...g.children]) { g.remove(o); o.geometry.dispose(); o.material.dispose(); }
  let cx = 0, cy = 0, cz = 0, n = 0;
  for (const [s, list] of state.sessions) {
    const pts = [];
    for (const k of list) { const p = poseOf(k); if (p) { pts.push(p[0], p[1], p[2]); cx += p[0]; cy += p[1]; cz += p[2]; ++n; } }
    if (pts.length >= 6) g.add(new THREE.Line(lineGeometry(pts), new THREE.LineBasicMaterial({ color: sessionColour(s) })));
  }
  const loops = [];
  for (const d of state.accepted) {
    const a = poseOf(state.keyframes.get(keyOf(d.q))), b = poseOf(state.keyframes.get(keyOf(d.m)));
    if (a && b) loops.push(a[0], a[1], a[2], b[0], b[1], b[2]);
  }
  if (loops.length) g.add(new THREE.LineSegments(lineGeometry(loops), new THREE.LineBasicMaterial({ color: STAGE_COLOURS.accepted })));
  if ($('show-cloud').checked) {
    const cloud = [];
    for (const key of state.clouds.keys()) cloudPoints(key, state.keyframes.get(key), (x, y, z) => cloud.push(x, y, z));
    if (cloud.length) g.add(new THREE.Points(lineGeometry(cloud), new THREE.PointsMaterial({ color: 0x555f70, size: 0.15 })));
  }
  if (n && !three.aimed && three.controls) {
    three.controls.target.set(cx / n, cy / n, cz / n);
    three.camera.position.set(cx / n - 60, cy / n - 60, cz / n + 70);
    three.controls.update();
    three.aimed = true;
  }
  three.needsRender = true;
}

function render3d() {
  const box = $('view3d');
  const w = box.clientWidth, h = box.clientHeight;
  if (three.w !== w || three.h !== h) {
    three.renderer.setSize(w, h);
    three.camera.aspect = w / Math.max(h, 1);
    three.camera.updateProjectionMatrix();
    three.w = w; three.h = h; three.needsRender = true;
  }
  if (three.needsRender) { three.renderer.render(three.scene, three.camera); three.needsRender = false; }
}

// ---- main loop -----------------------------------------------------------------------------------------------------

let last3d = -1e9;
function frame() {
  if (view.dirty) { view.dirty = false; drawTop(); }
  if (three.ok) {
    const t = Date.now();
    if (view.dirty3d && t - last3d > 500) { view.dirty3d = false; last3d = t; build3d(); }
    render3d();
  }
  requestAnimationFrame(frame);
}
window.addEventListener('resize', () => { view.dirty = true; });
init3d();
connect();
requestAnimationFrame(frame);
