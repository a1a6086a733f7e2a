// specula explore: the page. 3D: the scene from /api/scene, a receiver picked and dragged with the
// mouse, every solver's iterates, gradients and solutions from /api/solve, the loss map from
// /api/lossmap. 2D: a slice playground computed here (planes and circles, mirror and glass).
'use strict';

const $ = (id) => document.getElementById(id);
const COLORS = { angular: 0xffa040, newton: 0x60e060, conic: 0xe060e0, exact: 0x40d0ff };

async function api(path, body) {
  const opts = body ? { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body) } : {};
  const r = await fetch(path, opts);
  const j = await r.json();
  if (!r.ok) throw new Error(j.error || ('HTTP ' + r.status));
  return j;
}

function setStatus(text, ok) {
  const el = $('solver-status');
  el.textContent = text;
  el.className = ok ? 'ok' : 'fail';
}

// ---------------------------------------------------------------- 3D view
const V = {
  renderer: null, camera: null, scene: null, target: new THREE.Vector3(), radius: 1,
  pickables: [], overlay: null, ray: null, busy: false, pending: false, result: null, info: null,
};

function v3(a) { return new THREE.Vector3(a[0], a[1], a[2]); }

function material(s) {
  if (s.emitter) return new THREE.MeshBasicMaterial({ color: 0xffee88 });
  if (s.specular && s.eta > 0)
    return new THREE.MeshPhongMaterial({ color: 0x88bbff, transparent: true, opacity: 0.35, shininess: 90, side: THREE.DoubleSide, depthWrite: false });
  if (s.specular) return new THREE.MeshPhongMaterial({ color: 0xc8c8d0, shininess: 120, specular: 0xffffff, side: THREE.DoubleSide });
  const a = (s.albedo || [0.6, 0.6, 0.6]).map((c) => Math.pow(Math.max(0, Math.min(1, c)), 1 / 2.2));
  return new THREE.MeshLambertMaterial({ color: new THREE.Color(a[0], a[1], a[2]), side: THREE.DoubleSide });
}

function shapeObject(s) {
  let geo = null, m4 = null;
  if (s.type === 'mesh' || s.type === 'sdf') {
    geo = new THREE.BufferGeometry();
    geo.setAttribute('position', new THREE.Float32BufferAttribute(s.positions, 3));
    geo.setIndex(s.indices);
    geo.computeVertexNormals();
  } else if (s.type === 'sphere') {
    geo = new THREE.SphereBufferGeometry(s.radius, 48, 32);
    geo.translate(s.center[0], s.center[1], s.center[2]);
  } else if (s.type === 'disk') {
    geo = new THREE.CircleBufferGeometry(1, 48);
    m4 = s.to_world;
  } else if (s.type === 'cylinder') {
    // to_world maps the unit cylinder (radius 1, z from 0 to 1)
    geo = new THREE.CylinderBufferGeometry(1, 1, 1, 48, 1, true);
    geo.rotateX(Math.PI / 2);
    geo.translate(0, 0, 0.5);
    m4 = s.to_world;
  }
  if (!geo) return null;
  const mesh = new THREE.Mesh(geo, material(s));
  if (m4) {
    const M = new THREE.Matrix4();
    M.set(...m4);
    mesh.matrixAutoUpdate = false;
    mesh.matrix.copy(M);
  }
  mesh.userData = s;
  return mesh;
}

async function init3d() {
  const canvas = $('view3d');
  V.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
  V.scene = new THREE.Scene();
  V.scene.background = new THREE.Color(0x1d1f23);
  V.scene.add(new THREE.AmbientLight(0xffffff, 0.45));
  const sc = await api('/api/scene');
  V.info = sc;
  V.radius = sc.radius;
  const dl = new THREE.DirectionalLight(0xffffff, 0.6);
  dl.position.set(1, 2, 1.5);
  V.scene.add(dl);
  for (const s of sc.shapes) {
    const o = shapeObject(s);
    if (!o) continue;
    V.scene.add(o);
    V.pickables.push(o);
  }
  for (const l of sc.lights) {
    if (!l.position) continue;
    const m = new THREE.Mesh(new THREE.SphereBufferGeometry(0.015 * V.radius, 12, 8), new THREE.MeshBasicMaterial({ color: 0xffee66 }));
    m.position.copy(v3(l.position));
    V.scene.add(m);
  }
  V.overlay = new THREE.Group();
  V.scene.add(V.overlay);
  const c = sc.camera;
  V.camera = new THREE.PerspectiveCamera(40, 1, 1e-3 * V.radius, 100 * V.radius);
  V.camera.position.copy(v3(c.origin));
  V.camera.up.copy(v3(c.up));
  const mid = new THREE.Vector3().addVectors(v3(sc.bbox[0]), v3(sc.bbox[1])).multiplyScalar(0.5);
  const f = v3(c.forward);
  V.target.copy(v3(c.origin)).addScaledVector(f, Math.max(0.1 * V.radius, mid.clone().sub(v3(c.origin)).dot(f)));
  V.fov = c.fov;
  V.fovAxis = c.fov_axis;
  // the scene's camera as a small frustum (seen once the view is orbited away from it)
  const asp = c.width / c.height;
  let vf = c.fov;
  if (c.fov_axis === 'x') vf = 2 * Math.atan(Math.tan(c.fov * Math.PI / 360) / asp) * 180 / Math.PI;
  const sceneCam = new THREE.PerspectiveCamera(vf, asp, 0.02 * V.radius, 0.08 * V.radius);
  sceneCam.position.copy(v3(c.origin));
  sceneCam.up.copy(v3(c.up));
  sceneCam.lookAt(v3(c.origin).add(v3(c.forward)));
  sceneCam.updateMatrixWorld();
  V.scene.add(new THREE.CameraHelper(sceneCam));
  V.camera.lookAt(V.target);
  resize3d();
  window.addEventListener('resize', () => { resize3d(); resize2d(); });
  installMouse3d(canvas);
  $('light_sample').addEventListener('change', () => { V.lightRay = null; }); // back to sampled points
  for (const id of ['solver', 'max_chain', 'seed', 'seed_index', 'light_sample', 'method', 'loss', 'basins'])
    $(id).addEventListener('change', () => { if (V.ray) solve(); });
  $('iter').addEventListener('input', () => drawResult());
  $('next-seed').onclick = () => {
    if ($('seed').value !== 'cone') $('seed').value = 'cone';
    else $('seed_index').value = +$('seed_index').value + 1;
    if (V.ray) solve();
  };
  animate();
}

function resize3d() {
  const canvas = $('view3d');
  const w = canvas.clientWidth, h = canvas.clientHeight;
  if (!w || !h) return;
  V.renderer.setSize(w, h, false);
  V.camera.aspect = w / h;
  let fov = V.fov || 40;
  if (V.fovAxis === 'x') fov = 2 * Math.atan(Math.tan(fov * Math.PI / 360) / V.camera.aspect) * 180 / Math.PI;
  V.camera.fov = fov;
  V.camera.updateProjectionMatrix();
}

function animate() {
  requestAnimationFrame(animate);
  if ($('view3d').style.display !== 'none') V.renderer.render(V.scene, V.camera);
}

function pickRay(ev) {
  const canvas = $('view3d'), r = canvas.getBoundingClientRect();
  const ndc = new THREE.Vector2(((ev.clientX - r.left) / r.width) * 2 - 1, -((ev.clientY - r.top) / r.height) * 2 + 1);
  const rc = new THREE.Raycaster();
  rc.setFromCamera(ndc, V.camera);
  return rc;
}

function installMouse3d(canvas) {
  let mode = null, last = null;
  canvas.addEventListener('contextmenu', (e) => e.preventDefault());
  canvas.addEventListener('mousedown', (e) => {
    last = [e.clientX, e.clientY];
    if (e.button === 2 || e.shiftKey) { mode = 'orbit'; return; }
    if (e.ctrlKey || e.altKey) { pickLight(e); return; }
    mode = 'drag';
    placeReceiver(e);
  });
  window.addEventListener('mouseup', () => { mode = null; });
  canvas.addEventListener('mousemove', (e) => {
    if (!mode) return;
    if (mode === 'orbit') {
      const dx = e.clientX - last[0], dy = e.clientY - last[1];
      const off = V.camera.position.clone().sub(V.target);
      const sph = new THREE.Spherical().setFromVector3(off.applyQuaternion(upQuat()));
      sph.theta -= dx * 0.006;
      sph.phi = Math.min(Math.PI - 0.01, Math.max(0.01, sph.phi - dy * 0.006));
      const n = new THREE.Vector3().setFromSpherical(sph).applyQuaternion(upQuat().invert ? upQuat().invert() : upQuat().inverse());
      V.camera.position.copy(V.target).add(n);
      V.camera.lookAt(V.target);
    } else {
      placeReceiver(e);
    }
    last = [e.clientX, e.clientY];
  });
  canvas.addEventListener('wheel', (e) => {
    e.preventDefault();
    const off = V.camera.position.clone().sub(V.target).multiplyScalar(e.deltaY > 0 ? 1.1 : 1 / 1.1);
    V.camera.position.copy(V.target).add(off);
  }, { passive: false });
}

function upQuat() { return new THREE.Quaternion().setFromUnitVectors(V.camera.up.clone().normalize(), new THREE.Vector3(0, 1, 0)); }

function placeReceiver(ev) {
  const rc = pickRay(ev);
  const hits = rc.intersectObjects(V.pickables);
  if (!hits.length) return;
  V.ray = { origin: rc.ray.origin.toArray(), direction: rc.ray.direction.toArray() };
  solve();
}

// ctrl- or alt-click on an area light: y there (instead of specular NEE's sampled point)
function pickLight(ev) {
  const rc = pickRay(ev);
  V.lightRay = { origin: rc.ray.origin.toArray(), direction: rc.ray.direction.toArray() };
  if (V.ray) solve();
}

function request() {
  const req = {
    receiver: V.ray, solver: $('solver').value, max_chain: +$('max_chain').value, seed: $('seed').value,
    seed_index: +$('seed_index').value, light_sample: +$('light_sample').value, method: $('method').value, loss: $('loss').value,
  };
  if (V.lightRay) req.light = V.lightRay;
  return req;
}

// One solve in flight at a time; a drag during it leaves one more to do.
async function solve() {
  if (V.busy) { V.pending = true; return; }
  V.busy = true;
  try {
    const req = request();
    const res = await api('/api/solve', req);
    V.result = res;
    const ang = res.runs.find((r) => r.solver === 'angular');
    // the slider steps through the angular solver's iterates, or Newton's when it runs alone
    V.stepped = ang || res.runs.find((r) => r.solver === 'newton');
    $('iter').max = V.stepped ? Math.max(0, V.stepped.iterates.length - 1) : 0;
    $('iter').value = 0;
    drawResult();
    reportStatus(res);
    if (ang) lossMap(req, ang).catch((e) => { $('lossmap-info').textContent = e.message; });
  } catch (e) {
    V.result = null;
    clearOverlay();
    setStatus('failed: ' + e.message, false);
  }
  V.busy = false;
  if (V.pending) { V.pending = false; solve(); }
}

function runStatus(r) {
  if (r.solver === 'conic' || r.solver === 'exact')
    return r.success ? 'converged: ' + r.solutions.length + ' solution' + (r.solutions.length > 1 ? 's' : '') : 'failed: no solution';
  return r.success ? 'converged in ' + r.iterations + ' iteration' + (r.iterations > 1 ? 's' : '') : 'failed: ' + r.stop + ' after ' + r.iterations + ' iterations';
}

function reportStatus(res) {
  const runs = res.runs;
  if (runs.length === 1) setStatus(runStatus(runs[0]), runs[0].success);
  else setStatus(runs.map((r) => r.solver + ': ' + runStatus(r)).join('; '), runs.some((r) => r.success));
  let h = '<table><tr><th>solver</th><th>result</th><th>iter.</th><th>ms</th></tr>';
  for (const r of runs)
    h += '<tr><td><span class="sw" style="background:#' + COLORS[r.solver].toString(16).padStart(6, '0') + '"></span>' + r.solver +
      '</td><td>' + (r.success ? 'ok' : 'failed') + ': ' + r.stop + '</td><td>' + r.iterations + '</td><td>' + r.time_ms.toFixed(3) + '</td></tr>';
  $('runs').innerHTML = h + '</table>';
  let s = '<table><tr><th>solver</th><th>vertices</th><th>contribution (rgb)</th><th>G</th></tr>';
  for (const r of runs)
    for (const sol of r.solutions)
      s += '<tr><td>' + r.solver + '</td><td>' + sol.signature.map((v) => v[1] + v[0]).join(' ') + '</td><td>' +
        sol.contribution.map((x) => x.toPrecision(3)).join(', ') + '</td><td>' + sol.G.toPrecision(4) + '</td></tr>';
  $('solutions').innerHTML = s + '</table>';
}

function clearOverlay() {
  while (V.overlay.children.length) {
    const o = V.overlay.children.pop();
    if (o.geometry) o.geometry.dispose();
  }
}

function polyline(points, color, opacity) {
  const g = new THREE.BufferGeometry().setFromPoints(points.map(v3));
  return new THREE.Line(g, new THREE.LineBasicMaterial({ color, transparent: opacity < 1, opacity }));
}

function tube(points, color, r) {
  const grp = new THREE.Group();
  for (let i = 0; i + 1 < points.length; ++i) {
    const a = v3(points[i]), b = v3(points[i + 1]);
    const len = a.distanceTo(b);
    if (len <= 0) continue;
    const m = new THREE.Mesh(new THREE.CylinderBufferGeometry(r, r, len, 8), new THREE.MeshBasicMaterial({ color }));
    m.position.copy(a).add(b).multiplyScalar(0.5);
    m.quaternion.setFromUnitVectors(new THREE.Vector3(0, 1, 0), b.clone().sub(a).normalize());
    grp.add(m);
  }
  for (const p of points) grp.add(dot(p, color, 2 * r));
  return grp;
}

// An arrow drawn over everything (the glass would hide it)
function arrow(dir, origin, len, color, head, width) {
  const a = new THREE.ArrowHelper(dir, origin, len, color, head, width);
  for (const part of [a.line, a.cone]) { part.material.depthTest = false; part.renderOrder = 10; }
  return a;
}

function dot(p, color, r) {
  const m = new THREE.Mesh(new THREE.SphereBufferGeometry(r, 12, 8), new THREE.MeshBasicMaterial({ color }));
  m.position.copy(v3(p));
  return m;
}

function drawResult() {
  clearOverlay();
  const res = V.result;
  if (!res) return;
  const R = V.radius;
  V.overlay.add(dot(res.receiver.point, 0xffffff, 0.005 * R));
  V.overlay.add(dot(res.light.point, 0xffff40, 0.005 * R));
  const k = +$('iter').value;
  for (const run of res.runs) {
    const col = COLORS[run.solver];
    run.iterates.forEach((it, i) => {
      V.overlay.add(polyline(it.points, col, it.accepted ? 0.45 : 0.15));
      if (run === V.stepped && i === k) {
        V.overlay.add(tube(it.points, 0xffffff, 0.0007 * R));
        if (it.grad3) {
          // descent directions of the first segment, drawn from a point on it: the analytic one
          // and the finite difference's (they overlap when the derivatives are right)
          const p0 = v3(it.points[0]), p1 = v3(it.points[1]), seg = p1.distanceTo(p0);
          const L = 0.06 * R, x = p0.clone().lerp(p1, Math.min(0.35, 0.5 * L / Math.max(seg, 1e-12)));
          const ga = v3(it.grad3).negate(), gf = v3(it.grad_fd3).negate();
          if (ga.length() > 0) V.overlay.add(arrow(ga.normalize(), x, L, 0xff4040, 0.3 * L, 0.14 * L));
          if (gf.length() > 0) V.overlay.add(arrow(gf.normalize(), x, 0.8 * L, 0x40a0ff, 0.3 * L, 0.18 * L));
        }
        $('iter-label').textContent = k + ' of ' + (run.iterates.length - 1);
        $('iter-info').innerHTML = run.solver + ': ' + (it.accepted ? 'accepted' : 'rejected') + (it.end ? ', chain ' + it.end : '') +
          (it.loss !== undefined ? '<br>loss ' + fmt(it.loss) : '') +
          (it.constraints !== undefined ? '<br>|constraints|^2 ' + fmt(it.constraints) : '') +
          (it.grad ? '<br><span style="color:#f66">analytic grad</span> (' + it.grad.map(fmt).join(', ') + ')<br>' +
            '<span style="color:#6af">finite diff.</span> (' + it.grad_fd.map(fmt).join(', ') + ')' : '');
      }
    });
    for (const sol of run.solutions) V.overlay.add(tube(sol.points, col, 0.0012 * R));
  }
  if (V.map) drawLossMap();
}

function fmt(x) { return x === null ? 'n/a' : Number(x).toExponential(4); }

// ---------------------------------------------------------------- loss map
// One loss map in flight at a time; while it runs, only the latest request waits.
async function lossMap(req, run) {
  if (V.mapBusy) { V.mapPending = [req, run]; return; }
  V.mapBusy = true;
  try { await lossMapNow(req, run); } finally { V.mapBusy = false; }
  if (V.mapPending) { const p = V.mapPending; V.mapPending = null; return lossMap(p[0], p[1]); }
}

async function lossMapNow(req, run) {
  const seed = v3(run.seed_direction);
  // extent: every iterate's direction inside the map, in the seed's gnomonic coordinates
  const fr = frameOf(seed);
  let ext = 0.02;
  for (const it of run.iterates) {
    const d = v3(it.d0), dn = d.dot(fr.n);
    if (dn > 0.05) ext = Math.max(ext, Math.abs(d.dot(fr.s) / dn), Math.abs(d.dot(fr.t) / dn));
  }
  ext = Math.min(2, ext * 1.3);
  const basins = $('basins').checked;
  const body = Object.assign({}, req, { seed_direction: run.seed_direction, size: basins ? 48 : 64, extent: ext, basins });
  delete body.seed;
  delete body.solver;
  V.map = await api('/api/lossmap', body);
  V.map.run = run;
  drawLossMap();
}

function frameOf(n) {
  // the same frame as spc_frame_from_n (Duff et al. 2017), so the map's axes match the server's
  const sign = n.z >= 0 ? 1 : -1, a = -1 / (sign + n.z), b = n.x * n.y * a;
  return { s: new THREE.Vector3(1 + sign * n.x * n.x * a, sign * b, -sign * n.x), t: new THREE.Vector3(b, sign + n.y * n.y * a, -n.y), n };
}

function drawLossMap() {
  const m = V.map, cv = $('lossmap'), g = cv.getContext('2d');
  const N = m.size, W = cv.width, H = cv.height;
  let lo = Infinity, hi = -Infinity;
  for (const L of m.loss) if (L !== null && L > 0) { const l = Math.log10(L); lo = Math.min(lo, l); hi = Math.max(hi, l); }
  const img = g.createImageData(N, N);
  for (let j = 0; j < m.rows; ++j)
    for (let i = 0; i < N; ++i) {
      const L = m.loss[j * N + i], o = 4 * ((N - 1 - j) * N + i);
      if (L === null) { img.data[o] = img.data[o + 1] = img.data[o + 2] = 60; img.data[o + 3] = 255; continue; }
      const u = hi > lo ? (Math.log10(Math.max(L, 1e-300)) - lo) / (hi - lo) : 0;
      const c = viridis(Math.max(0, Math.min(1, u)));
      const sig = m.signature[j * N + i];
      const edge = (i > 0 && m.signature[j * N + i - 1] !== sig) || (j > 0 && m.signature[(j - 1) * N + i] !== sig);
      if (m.basin) {
        // basins: the solution's hue over the loss's brightness; no solution: dark
        const bid = m.basin[j * N + i], v = 0.35 + 0.65 * (1 - u);
        const h = bid < 0 ? null : new THREE.Color().setHSL((bid * 0.618034) % 1, 0.85, 0.25 + 0.35 * v);
        if (h) { c[0] = 255 * h.r; c[1] = 255 * h.g; c[2] = 255 * h.b; } else { c[0] = c[1] = c[2] = 25; }
      }
      img.data[o] = edge ? 255 : c[0]; img.data[o + 1] = edge ? 255 : c[1]; img.data[o + 2] = edge ? 255 : c[2]; img.data[o + 3] = 255;
    }
  const tmp = document.createElement('canvas');
  tmp.width = tmp.height = N;
  tmp.getContext('2d').putImageData(img, 0, 0);
  g.imageSmoothingEnabled = false;
  g.drawImage(tmp, 0, 0, W, H);
  // the iterates, in the seed's gnomonic coordinates
  const fr = { s: v3(m.frame.s), t: v3(m.frame.t), n: v3(m.frame.n) };
  const toPx = (d) => { const dn = d.dot(fr.n); return [(d.dot(fr.s) / dn / m.extent * 0.5 + 0.5) * W, (0.5 - d.dot(fr.t) / dn / m.extent * 0.5) * H]; };
  g.strokeStyle = '#fff'; g.lineWidth = 1.5; g.beginPath();
  const acc = m.run.iterates.filter((it) => it.accepted);
  acc.forEach((it, i) => { const p = toPx(v3(it.d0)); if (i) g.lineTo(p[0], p[1]); else g.moveTo(p[0], p[1]); });
  g.stroke();
  acc.forEach((it, i) => { const p = toPx(v3(it.d0)); g.fillStyle = i === acc.length - 1 ? (m.run.success ? '#4f4' : '#f44') : '#fff'; g.beginPath(); g.arc(p[0], p[1], 3, 0, 7); g.fill(); });
  if (m.solutions) // the solutions the basins lead to, as rings
    for (const sd of m.solutions) { const p = toPx(v3(sd)); g.strokeStyle = '#fff'; g.lineWidth = 2; g.beginPath(); g.arc(p[0], p[1], 6, 0, 7); g.stroke(); }
  $('lossmap-info').textContent = (m.solutions ? m.solutions.length + (m.solutions.length === 1 ? ' solution' : ' solutions') + ' reached; ' : '') + 'a, b in [-' + m.extent.toPrecision(3) + ', ' + m.extent.toPrecision(3) + '], log10 loss ' +
    lo.toFixed(1) + ' .. ' + hi.toFixed(1) + '; grey: no chain; white lines: the chain\'s surfaces change';
}

function viridis(u) {
  const stops = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
  const x = u * (stops.length - 1), i = Math.min(stops.length - 2, Math.floor(x)), f = x - i;
  return stops[i].map((c, k) => Math.round(c + f * (stops[i + 1][k] - c)));
}

// ---------------------------------------------------------------- tabs
function showTab(which) {
  const is3 = which === '3d';
  $('view3d').style.display = is3 ? '' : 'none';
  $('view2d').style.display = is3 ? 'none' : '';
  $('tab3d').className = is3 ? 'on' : '';
  $('tab2d').className = is3 ? '' : 'on';
  for (const el of document.querySelectorAll('.only3d')) el.style.display = is3 ? '' : 'none';
  for (const el of document.querySelectorAll('.only2d')) el.style.display = is3 ? 'none' : 'block';
  $('help').textContent = is3 ? 'left click / drag on a diffuse surface: receiver x · ctrl-click on a light: y · right drag: orbit · wheel: zoom'
    : 'drag x, y, the aim handle or shapes · the ray follows up to 10 bounces';
  if (is3) resize3d(); else { resize2d(); draw2d(); }
}

// For tests and scripts: the pixel (client coordinates) of a world point in the 3D view.
window.specula = {
  project(p) {
    const v = v3(p).project(V.camera), r = $('view3d').getBoundingClientRect();
    return [r.left + (v.x + 1) / 2 * r.width, r.top + (1 - v.y) / 2 * r.height];
  },
  result() { return V.result; },
};

$('tab3d').onclick = () => showTab('3d');
$('tab2d').onclick = () => showTab('2d');

// ---------------------------------------------------------------- 2D view
// A slice: planes (segments) and circles, mirror or glass, a start x, a target y and the ray's
// angle theta at x. The ray is traced through up to 10 bounces with the derivatives of its points
// and directions by theta (the 2D counterpart of the chain's derivatives), the loss is the squared
// distance from y to the final segment (Dadfar 2022, eq. 17-20), its analytic derivative is drawn
// against a central finite difference, and the loss over every theta with the solutions as the
// roots of the signed distance from y to the final line.
const MAXB = 10;
const P = { shapes: [], x: [0, 0], y: [0, 0], theta: 0, sel: -1, iterates: [], roots: [], view: null };
const PRESETS = {
  'glass ball': () => ({ x: [0.1, -0.9], y: [-0.09, 1.0], shapes: [{ kind: 'circle', c: [0, 0.1], r: 0.4, mat: 'glass', eta: 1.5 }] }),
  'two mirrors': () => ({ x: [-0.9, -0.6], y: [0.9, -0.6], shapes: [
    { kind: 'plane', c: [-0.3, 0.6], ang: -1.09, half: 0.3, mat: 'mirror' },
    { kind: 'plane', c: [0.4, 0.5], ang: -2.21, half: 0.3, mat: 'mirror' }] }),
  'lens and mirror': () => ({ x: [-1.1, -0.7], y: [1.1, -0.7], shapes: [
    { kind: 'circle', c: [-0.35, 0.1], r: 0.3, mat: 'glass', eta: 1.5 },
    { kind: 'plane', c: [0.5, 0.8], ang: -Math.PI / 2, half: 0.7, mat: 'mirror' }] }),
  'glass slab': () => ({ x: [-0.8, -0.8], y: [0.7, 0.9], shapes: [
    { kind: 'plane', c: [0, -0.1], ang: -Math.PI / 2 + 0.2, half: 0.9, mat: 'glass', eta: 1.5 },
    { kind: 'plane', c: [-0.04, 0.25], ang: Math.PI / 2 + 0.2, half: 0.9, mat: 'glass', eta: 1.5 }] }),
};

const add2 = (a, b) => [a[0] + b[0], a[1] + b[1]];
const sub2 = (a, b) => [a[0] - b[0], a[1] - b[1]];
const mul2 = (a, s) => [a[0] * s, a[1] * s];
const dot2 = (a, b) => a[0] * b[0] + a[1] * b[1];

function loadPreset(name) {
  const p = PRESETS[name]();
  P.shapes = p.shapes; P.x = p.x; P.y = p.y; P.sel = -1; P.iterates = [];
  // start a little off the line from x to the first shape, so that a solve has something to do
  const c0 = P.shapes[0].c;
  P.theta = Math.atan2(c0[1] - P.x[1], c0[0] - P.x[0]) + 0.05;
  update2d();
}

// Nearest hit of the ray (o, d) after distance 1e-9: {t, i, n (unit, outward), dn/dp factor}.
function hit2(o, d, skip) {
  let best = null;
  P.shapes.forEach((s, i) => {
    if (s.kind === 'plane') {
      const n = [Math.cos(s.ang), Math.sin(s.ang)], nd = dot2(n, d);
      if (Math.abs(nd) < 1e-12) return;
      const t = dot2(n, sub2(s.c, o)) / nd;
      const p = add2(o, mul2(d, t));
      if (t > 1e-9 && Math.abs(dot2(sub2(p, s.c), [-n[1], n[0]])) <= s.half && (!best || t < best.t) && !(i === skip && t < 1e-7))
        best = { t, i, n };
    } else {
      const oc = sub2(o, s.c), b = dot2(oc, d), c = dot2(oc, oc) - s.r * s.r, disc = b * b - c;
      if (disc < 0) return;
      const sq = Math.sqrt(disc);
      for (const t of [-b - sq, -b + sq])
        if (t > 1e-9 && !(i === skip && t < 1e-7) && (!best || t < best.t)) {
          const p = add2(o, mul2(d, t));
          best = { t, i, n: mul2(sub2(p, s.c), 1 / s.r) };
          break;
        }
    }
  });
  return best;
}

// Traces from x along theta; returns the points, the signature, the final ray with derivatives,
// the loss, its analytic derivative and the closest point.
function trace2(theta) {
  let o = P.x.slice(), d = [Math.cos(theta), Math.sin(theta)];
  let dO = [0, 0], dD = [-Math.sin(theta), Math.cos(theta)];
  const pts = [o.slice()], sig = [];
  let skip = -1, end = 'escaped';
  for (let k = 0; k < MAXB; ++k) {
    const h = hit2(o, d, skip);
    if (!h) break;
    const s = P.shapes[h.i];
    const t = h.t, p = add2(o, mul2(d, t));
    let n = h.n, dn = [0, 0], dt;
    if (s.kind === 'plane') dt = -(dot2(n, dO) + t * dot2(n, dD)) / dot2(n, d);
    else dt = -dot2(sub2(p, s.c), add2(dO, mul2(dD, t))) / dot2(sub2(p, s.c), d);
    const dp = add2(add2(dO, mul2(d, dt)), mul2(dD, t));
    if (s.kind === 'circle') dn = mul2(dp, 1 / s.r);
    let cosI = -dot2(d, n), eta = 1;
    if (cosI < 0) { n = mul2(n, -1); dn = mul2(dn, -1); cosI = -cosI; eta = s.mat === 'glass' ? s.eta : 1; }
    else eta = s.mat === 'glass' ? 1 / s.eta : 1;
    const dcos = -(dot2(dD, n) + dot2(d, dn));
    let nd, ndD, ev = 'R';
    const kk = 1 - eta * eta * (1 - cosI * cosI);
    if (s.mat === 'glass' && kk > 0) {
      const sk = Math.sqrt(kk), dk = 2 * eta * eta * cosI * dcos, dsk = dk / (2 * sk);
      nd = add2(mul2(d, eta), mul2(n, eta * cosI - sk));
      ndD = add2(add2(mul2(dD, eta), mul2(n, eta * dcos - dsk)), mul2(dn, eta * cosI - sk));
      ev = 'T';
    } else {
      // d' = d + 2 cosI n
      nd = add2(d, mul2(n, 2 * cosI));
      ndD = add2(add2(dD, mul2(n, 2 * dcos)), mul2(dn, 2 * cosI));
    }
    pts.push(p); sig.push(ev + h.i);
    o = p; dO = dp; d = nd; dD = ndD; skip = h.i;
    if (k === MAXB - 1) end = 'bounce limit';
  }
  const w = sub2(P.y, o), sproj = dot2(w, d);
  let q, dq;
  if (sproj > 0) {
    const ds = -dot2(dO, d) + dot2(w, dD);
    q = add2(o, mul2(d, sproj)); dq = add2(add2(dO, mul2(d, ds)), mul2(dD, sproj));
  } else { q = o; dq = dO; }
  const r = sub2(q, P.y), L = dot2(r, r);
  return { pts, sig: sig.join(' '), o, d, q, r, dq, L, g: 2 * dot2(r, dq), ahead: sproj > 0,
    signed: d[0] * w[1] - d[1] * w[0], end };
}

function fd2(theta, h) {
  const a = trace2(theta + h), b = trace2(theta - h), c = trace2(theta);
  if (a.sig !== c.sig || b.sig !== c.sig) return NaN;
  return (a.L - b.L) / (2 * h);
}

// Roots of the signed distance from y to the final line over theta (same signature on both sides
// of a sign change, y ahead), by bisection.
function roots2() {
  const N = 1440, out = [];
  let prev = null;
  for (let i = 0; i <= N; ++i) {
    const th = -Math.PI + 2 * Math.PI * i / N, tr = trace2(th);
    const cur = { th, f: tr.signed, sig: tr.sig, ok: tr.ahead && tr.pts.length > 1 };
    if (prev && prev.ok && cur.ok && prev.sig === cur.sig && (prev.f < 0) !== (cur.f < 0)) {
      let a = prev.th, b = th, fa = prev.f;
      for (let k = 0; k < 60; ++k) {
        const m = 0.5 * (a + b), fm = trace2(m).signed;
        if ((fm < 0) === (fa < 0)) { a = m; fa = fm; } else b = m;
      }
      const th0 = 0.5 * (a + b), t0 = trace2(th0);
      if (t0.L < 1e-12) out.push({ theta: th0, sig: t0.sig });
    }
    prev = cur;
  }
  return out;
}

// Gauss-Newton on theta from the current angle, with step halving; records the iterates.
function solve2d() {
  let th = P.theta, tr = trace2(th);
  const its = [th];
  const sig0 = tr.sig;
  let msg = null, n = 1;
  for (; n < 60 && tr.L > 1e-20; ++n) {
    const jj = dot2(tr.dq, tr.dq);
    if (!(jj > 0)) { msg = 'zero derivative'; break; }
    let step = -dot2(tr.r, tr.dq) / jj, ok = false;
    step = Math.max(-0.5, Math.min(0.5, step));
    for (let k = 0; k < 30; ++k, step *= 0.5) {
      const t2 = trace2(th + step);
      if (t2.sig === sig0 && t2.L < tr.L) { th += step; tr = t2; ok = true; break; }
    }
    its.push(th);
    if (!ok) { msg = 'no step lowers the loss (local minimum)'; break; }
  }
  P.theta = th;
  P.iterates = its;
  const conv = tr.L <= 1e-20 || Math.sqrt(tr.L) < 1e-9;
  const direct = tr.pts.length < 2 ? ' (the direct line, no bounce)' : '';
  setStatus(conv ? '2D: converged in ' + n + ' iterations' + direct : '2D: failed: ' + (msg || 'iteration limit'), conv);
  update2d(true);
}

function resize2d() {
  const cv = $('view2d');
  if (!cv.clientWidth) return;
  cv.width = cv.clientWidth; cv.height = cv.clientHeight;
  const s = Math.min(cv.width / 3.4, cv.height / 2.4);
  P.view = { s, cx: cv.width / 2, cy: cv.height / 2 };
}
const toS = (p) => [P.view.cx + p[0] * P.view.s, P.view.cy - p[1] * P.view.s];
const toW = (q) => [(q[0] - P.view.cx) / P.view.s, (P.view.cy - q[1]) / P.view.s];

function update2d(keepIterates) {
  if (!keepIterates) P.iterates = [];
  P.roots = roots2();
  draw2d();
}

function draw2d() {
  const cv = $('view2d');
  if (!P.view || cv.style.display === 'none') return;
  const g = cv.getContext('2d');
  g.fillStyle = '#1d1f23'; g.fillRect(0, 0, cv.width, cv.height);
  const line = (pts, color, w, dash) => {
    g.strokeStyle = color; g.lineWidth = w; g.setLineDash(dash || []); g.beginPath();
    pts.forEach((p, i) => { const q = toS(p); if (i) g.lineTo(q[0], q[1]); else g.moveTo(q[0], q[1]); });
    g.stroke(); g.setLineDash([]);
  };
  const disc = (p, r, color) => { const q = toS(p); g.fillStyle = color; g.beginPath(); g.arc(q[0], q[1], r, 0, 7); g.fill(); };
  P.shapes.forEach((s, i) => {
    const color = s.mat === 'glass' ? '#6ab0ff' : '#d0d0d8', w = i === P.sel ? 4 : 2;
    if (s.kind === 'plane') {
      const t = [-Math.sin(s.ang), Math.cos(s.ang)], n = [Math.cos(s.ang), Math.sin(s.ang)];
      line([add2(s.c, mul2(t, -s.half)), add2(s.c, mul2(t, s.half))], color, w);
      line([s.c, add2(s.c, mul2(n, 0.08))], color, 1);
    } else {
      const q = toS(s.c);
      g.strokeStyle = color; g.lineWidth = w; g.beginPath(); g.arc(q[0], q[1], s.r * P.view.s, 0, 7); g.stroke();
      if (s.mat === 'glass') { g.fillStyle = 'rgba(106,176,255,0.12)'; g.fill(); }
    }
  });
  const far = (tr) => tr.pts.concat([add2(tr.o, mul2(tr.d, 4))]);
  for (const r of P.roots) line(far(trace2(r.theta)), 'rgba(80,230,120,0.55)', 1.5);
  for (const th of P.iterates) line(far(trace2(th)), 'rgba(255,160,64,0.35)', 1);
  const tr = trace2(P.theta);
  line(far(tr), '#ffa040', 2);
  tr.pts.slice(1).forEach((p) => disc(p, 3.5, '#ffa040'));
  line([tr.q, P.y], '#ff5050', 1, [4, 3]);
  disc(tr.q, 4, '#ff5050');
  disc(P.x, 6, '#ffffff');
  disc(P.y, 6, '#ffee44');
  const aim = add2(P.x, [0.3 * Math.cos(P.theta), 0.3 * Math.sin(P.theta)]);
  disc(aim, 5, '#ff9020');
  // the two derivatives as arrows across the ray at x (descent: -dL/dtheta), scaled together
  const gfd = fd2(P.theta, 1e-6), tang = [-Math.sin(P.theta), Math.cos(P.theta)];
  const m = Math.max(Math.abs(tr.g), Math.abs(gfd) || 0) || 1;
  const arrow = (gv, color, off) => {
    if (!isFinite(gv)) return;
    const base = add2(P.x, mul2([Math.cos(P.theta), Math.sin(P.theta)], off));
    line([base, add2(base, mul2(tang, -0.25 * gv / m))], color, 3);
  };
  arrow(tr.g, '#ff4040', 0.15);
  arrow(gfd, '#40a0ff', 0.2);
  $('info2d').innerHTML = 'theta ' + P.theta.toFixed(6) + ', bounces ' + (tr.pts.length - 1) + ' (' + (tr.sig || 'none') + ')<br>loss ' +
    fmt(tr.L) + '<br><span style="color:#f66">dL/dtheta analytic ' + fmt(tr.g) + '</span><br><span style="color:#6af">finite difference ' +
    fmt(isFinite(gfd) ? gfd : null) + '</span><br>solutions (roots): ' + P.roots.length;
  plot2d(tr);
}

function plot2d(cur) {
  const cv = $('plot2d'), g = cv.getContext('2d'), W = cv.width, H = cv.height, N = 720;
  g.fillStyle = '#111'; g.fillRect(0, 0, W, H);
  const vals = [];
  for (let i = 0; i <= N; ++i) {
    const th = -Math.PI + 2 * Math.PI * i / N, tr = trace2(th);
    vals.push(Math.log10(Math.max(tr.L, 1e-16)));
  }
  const fin = vals.filter((v) => v !== null);
  const lo = Math.min(-8, ...fin), hi = Math.max(0, ...fin);
  const X = (th) => (th + Math.PI) / (2 * Math.PI) * W, Y = (v) => H - 4 - (v - lo) / (hi - lo) * (H - 8);
  g.strokeStyle = '#ffa040'; g.lineWidth = 1; g.beginPath();
  let pen = false;
  vals.forEach((v, i) => {
    const th = -Math.PI + 2 * Math.PI * i / N;
    if (v === null) { pen = false; return; }
    if (pen) g.lineTo(X(th), Y(v)); else g.moveTo(X(th), Y(v));
    pen = true;
  });
  g.stroke();
  g.fillStyle = '#50e678';
  for (const r of P.roots) { g.beginPath(); g.arc(X(r.theta), Y(lo), 4, 0, 7); g.fill(); }
  g.strokeStyle = '#fff'; g.beginPath(); g.moveTo(X(wrap(P.theta)), 0); g.lineTo(X(wrap(P.theta)), H); g.stroke();
  g.fillStyle = '#99a'; g.font = '10px sans-serif';
  g.fillText('log10 loss ' + hi.toFixed(0) + ' .. ' + lo.toFixed(0) + ', theta -pi .. pi; green: solutions', 4, 12);
}
function wrap(t) { return Math.atan2(Math.sin(t), Math.cos(t)); }

function install2d() {
  const sel = $('preset2d');
  for (const k of Object.keys(PRESETS)) { const o = document.createElement('option'); o.value = o.textContent = k; sel.appendChild(o); }
  sel.onchange = () => loadPreset(sel.value);
  $('add-mirror').onclick = () => { P.shapes.push({ kind: 'plane', c: [0, 0.6], ang: -Math.PI / 2, half: 0.4, mat: 'mirror' }); update2d(); };
  $('add-glass').onclick = () => { P.shapes.push({ kind: 'circle', c: [0.5, 0.2], r: 0.25, mat: 'glass', eta: 1.5 }); update2d(); };
  $('add-glass-plane').onclick = () => { P.shapes.push({ kind: 'plane', c: [0, 0.3], ang: -Math.PI / 2, half: 0.6, mat: 'glass', eta: 1.5 }); update2d(); };
  $('solve2d').onclick = solve2d;
  const cv = $('view2d');
  let drag = null;
  const near = (a, b, px) => Math.hypot(...sub2(toS(a), toS(b))) < px;
  cv.addEventListener('mousedown', (e) => {
    const r = cv.getBoundingClientRect(), w = toW([e.clientX - r.left, e.clientY - r.top]);
    const aim = add2(P.x, [0.3 * Math.cos(P.theta), 0.3 * Math.sin(P.theta)]);
    if (near(w, aim, 9)) drag = { what: 'aim' };
    else if (near(w, P.x, 9)) drag = { what: 'x' };
    else if (near(w, P.y, 9)) drag = { what: 'y' };
    else {
      P.sel = -1;
      P.shapes.forEach((s, i) => {
        const d = s.kind === 'circle' ? Math.abs(Math.hypot(...sub2(w, s.c)) - s.r) : Math.abs(dot2(sub2(w, s.c), [Math.cos(s.ang), Math.sin(s.ang)]));
        const inside = s.kind === 'circle' ? true : Math.abs(dot2(sub2(w, s.c), [-Math.sin(s.ang), Math.cos(s.ang)])) <= s.half;
        if (inside && (d * P.view.s < 8 || (s.kind === 'circle' && Math.hypot(...sub2(w, s.c)) < s.r))) P.sel = i;
      });
      if (P.sel >= 0) drag = { what: 'shape', off: sub2(P.shapes[P.sel].c, w) };
    }
    draw2d();
  });
  window.addEventListener('mouseup', () => { drag = null; });
  cv.addEventListener('mousemove', (e) => {
    if (!drag) return;
    const r = cv.getBoundingClientRect(), w = toW([e.clientX - r.left, e.clientY - r.top]);
    if (drag.what === 'aim') P.theta = Math.atan2(w[1] - P.x[1], w[0] - P.x[0]);
    else if (drag.what === 'x') P.x = w;
    else if (drag.what === 'y') P.y = w;
    else P.shapes[P.sel].c = add2(w, drag.off);
    update2d();
  });
  cv.addEventListener('wheel', (e) => {
    if (P.sel < 0) return;
    e.preventDefault();
    const s = P.shapes[P.sel];
    if (s.kind === 'circle') s.r = Math.max(0.02, s.r * (e.deltaY > 0 ? 0.95 : 1.05));
    else s.ang += e.deltaY > 0 ? 0.03 : -0.03;
    update2d();
  }, { passive: false });
  window.addEventListener('keydown', (e) => {
    if ((e.key === 'Delete' || e.key === 'Backspace') && P.sel >= 0 && $('view2d').style.display !== 'none') {
      P.shapes.splice(P.sel, 1); P.sel = -1; update2d();
    }
  });
  loadPreset('glass ball');
}
install2d();
init3d().then(() => { $('scene-name').textContent = 'scene: ' + V.info.shapes.length + ' shapes, radius ' + V.radius.toPrecision(3); })
  .catch((e) => setStatus('failed: ' + e.message, false));
