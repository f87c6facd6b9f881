// meshgauge report page, the interactive view: the mesh coloured by
// thickness (three.js, bundled as the global MG3 by
// scripts/install_web_deps.sh), orbit / zoom / pan, hover and click
// read-outs, a t_min slider that recolours, re-outlines and recomputes the
// thin share and the bands exactly (the formulas of lib/core/thin_regions.cc),
// and region rows that fly the camera. Reads the JSON in
// <script id="mg-data">; writes nothing outside the page and fetches nothing.
// `#selftest=T1,T2` in the URL runs a self-test (tests/report_page_test.cc)
// and writes its results into <pre id="mg-selftest">.
(function () {
  'use strict';
  const found = { errors: [] };
  const note = (kind) => function () {
    found.errors.push(kind + ': ' + Array.prototype.join.call(arguments, ' '));
  };
  window.addEventListener('error', (e) => found.errors.push('error: ' + e.message));
  const origError = console.error, origWarn = console.warn;
  console.error = function () { note('console.error').apply(null, arguments); origError.apply(console, arguments); };
  console.warn = function () { note('console.warn').apply(null, arguments); origWarn.apply(console, arguments); };

  const $ = (id) => document.getElementById(id);
  const data = JSON.parse($('mg-data').textContent);
  const T = window.MG3;

  // ---- numbers (the CLI's formulas) ----
  // printf's %g with `digits` significant digits.
  function fmtG(x, digits) {
    if (!isFinite(x)) return String(x);
    if (x === 0) return '0';
    const e = Math.floor(Math.log10(Math.abs(Number(x.toPrecision(digits)))));
    let s;
    if (e < -4 || e >= digits) {
      const m = x.toExponential(digits - 1).split('e');
      let mant = m[0];
      if (mant.indexOf('.') >= 0) mant = mant.replace(/0+$/, '').replace(/\.$/, '');
      const ex = Number(m[1]);
      s = mant + 'e' + (ex < 0 ? '-' : '+') + String(Math.abs(ex)).padStart(2, '0');
    } else {
      s = x.toFixed(Math.max(0, digits - 1 - e));
      if (s.indexOf('.') >= 0) s = s.replace(/0+$/, '').replace(/\.$/, '');
    }
    return s;
  }
  // client/cli/thin_summary.cc Percent: 3 significant digits, more where a
  // share below 1 would print as 100.
  function percent(share) {
    let text = '';
    for (let d = 3; d <= 17; ++d) {
      text = fmtG(100 * share, d);
      if (share >= 1 || text !== '100') break;
    }
    return text;
  }
  // lib/core/thin_regions.cc TriangleAreaBelow.
  function triangleBelow(area, a, b, c, s) {
    let t;
    if (a > b) { t = a; a = b; b = t; }
    if (b > c) { t = b; b = c; c = t; }
    if (a > b) { t = a; a = b; b = t; }
    if (s <= a) return 0;
    if (s >= c) return area;
    if (s <= b) return area * ((s - a) / (b - a)) * ((s - a) / (c - a));
    return area - area * ((c - s) / (c - a)) * ((c - s) / (c - b));
  }
  function segmentBelow(len, a, b, s) {
    const lo = Math.min(a, b), hi = Math.max(a, b);
    if (s <= lo) return 0;
    if (s >= hi) return len;
    return len * (s - lo) / (hi - lo);
  }

  // ---- the shown mesh ----
  function bytes(b64) {
    const bin = atob(b64);
    const out = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; ++i) out[i] = bin.charCodeAt(i);
    return out.buffer;
  }
  const P = (function () {
    const spec = data.positions;
    if (spec.dtype === 'f64') return new Float64Array(bytes(spec.b64));
    const q = new Uint16Array(bytes(spec.b64));
    const out = new Float64Array(q.length);
    for (let i = 0; i < q.length; ++i) {
      const a = i % 3, lo = spec.box_min[a], hi = spec.box_max[a];
      out[i] = lo + (hi - lo) * (q[i] / 65535);
    }
    return out;
  })();
  const V = data.values.dtype === 'f64' ? new Float64Array(bytes(data.values.b64))
                                        : Float64Array.from(new Float32Array(bytes(data.values.b64)));
  const EL = new Uint32Array(bytes(data.elements.b64));
  const n = data.elements.arity;  // 3: triangles, 2: segments (2D).
  const faces = data.samples === 'faces';  // V per element, else per vertex.
  const E = EL.length / n;
  const NV = P.length / 3;
  const value = faces ? (e, k) => V[e] : (e, k) => V[EL[e * n + k]];
  const measure = new Float64Array(E);
  const valued = new Uint8Array(E);
  let totalArea = 0, missingArea = 0;
  for (let e = 0; e < E; ++e) {
    const i0 = 3 * EL[e * n], i1 = 3 * EL[e * n + 1];
    let m;
    if (n === 2) {
      m = Math.hypot(P[i1] - P[i0], P[i1 + 1] - P[i0 + 1], P[i1 + 2] - P[i0 + 2]);
    } else {
      const i2 = 3 * EL[e * n + 2];
      const ux = P[i1] - P[i0], uy = P[i1 + 1] - P[i0 + 1], uz = P[i1 + 2] - P[i0 + 2];
      const vx = P[i2] - P[i0], vy = P[i2 + 1] - P[i0 + 1], vz = P[i2 + 2] - P[i0 + 2];
      const cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
      m = Math.sqrt(cx * cx + cy * cy + cz * cz) / 2;
    }
    measure[e] = m;
    totalArea += m;
    let ok = 1;
    for (let k = 0; k < n; ++k) if (isNaN(value(e, k))) ok = 0;
    valued[e] = ok;
    if (!ok) missingArea += m;
  }
  // The measure of the valued elements whose interpolated value is below s.
  function measureBelow(s) {
    let sum = 0;
    for (let e = 0; e < E; ++e) {
      if (!valued[e]) continue;
      sum += n === 3 ? triangleBelow(measure[e], value(e, 0), value(e, 1), value(e, 2), s)
                     : segmentBelow(measure[e], value(e, 0), value(e, 1), s);
    }
    return sum;
  }

  // ---- live numbers: the sentence, the bands ----
  let tMin = data.t_min;
  const state = {};
  const answer = $('mg-answer');
  const sentence = answer ? answer.textContent : '';
  const restAt = sentence.indexOf('; thinnest');
  const rest = restAt >= 0 ? sentence.slice(restAt) : '';
  const word = data.curve ? 'curve' : 'surface', mword = data.curve ? 'length' : 'area';
  // live: write them into the page (at load the page holds the report's
  // exact numbers already).
  function updateNumbers(live) {
    const below = measureBelow(tMin), within = measureBelow(tMin * 1.1) - below;
    const valuedArea = totalArea - missingArea;
    const above = valuedArea - below - within;
    const share = (a) => (totalArea > 0 ? a / totalArea : 0);
    state.thin_area = below;
    state.total_area = totalArea;
    state.thin_fraction = share(below);
    state.bands = { below: below, within: within, above: above, missing: missingArea };
    if (!live) return;
    if (answer) {
      answer.textContent = percent(share(below)) + ' % of the ' + word + ' (' + mword + ' ' +
          fmtG(below, 4) + ' of ' + fmtG(totalArea, 4) + ') is thinner than ' + fmtG(tMin, 6) + rest;
      answer.setAttribute('data-thin-fraction', String(state.thin_fraction));
    }
    const label = { below: 't < ' + fmtG(tMin, 6),
                    within: fmtG(tMin, 6) + ' \u2264 t < ' + fmtG(tMin * 1.1, 6),
                    above: 't \u2265 ' + fmtG(tMin * 1.1, 6), missing: 'no value' };
    for (const row of document.querySelectorAll('tr[data-band]')) {
      const b = row.getAttribute('data-band');
      row.querySelector('.range').textContent = label[b];
      row.querySelector('.area').textContent = fmtG(state.bands[b], 6);
      row.querySelector('.share').textContent = percent(share(state.bands[b])) + ' %';
    }
    const out = $('mg-tmin-value');
    if (out) out.value = fmtG(tMin, 6);
  }

  // ---- colours: lib/core/colormap.cc in OKLab ----
  function thicknessColor(s) {
    s = Math.min(Math.max(s, 0), 1);
    const L = 0.30 + 0.63 * s, hue = (300.0 - 195.0 * s) * Math.PI / 180;
    const ca = Math.cos(hue), sa = Math.sin(hue);
    const rgb = [0, 0, 0];
    const toLinear = (C) => {
      const a = C * ca, b = C * sa;
      const l = Math.pow(L + 0.3963377774 * a + 0.2158037573 * b, 3);
      const m = Math.pow(L - 0.1055613458 * a - 0.0638541728 * b, 3);
      const q = Math.pow(L - 0.0894841775 * a - 1.2914855480 * b, 3);
      rgb[0] = 4.0767416621 * l - 3.3077115913 * m + 0.2309699292 * q;
      rgb[1] = -1.2684380046 * l + 2.6097574011 * m - 0.3413193965 * q;
      rgb[2] = -0.0041960863 * l - 0.7034186147 * m + 1.7076147010 * q;
      return Math.min(rgb[0], rgb[1], rgb[2]) >= 0 && Math.max(rgb[0], rgb[1], rgb[2]) <= 1;
    };
    let lo = 0, hi = 0.13;
    if (!toLinear(hi)) {
      for (let i = 0; i < 30; ++i) {
        const mid = 0.5 * (lo + hi);
        if (toLinear(mid)) lo = mid; else hi = mid;
      }
      toLinear(lo);
    }
    const enc = (x) => {
      x = Math.min(Math.max(x, 0), 1);
      return Math.round(255 * (x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055));
    };
    return [enc(rgb[0]), enc(rgb[1]), enc(rgb[2])];
  }
  const range = data.color_range;
  const colourRange = () => (range.source === 'default' ? [0, 2 * tMin] : [range.low, range.high]);
  // A 1024 x 1 texture: texels 0..767 the map over [lo, hi], 768.. the
  // overflow colour; u = 0.75 (t - lo) / (hi - lo), so that the interpolated
  // u crosses into the overflow colour where the interpolated t crosses hi.
  const RAMP = 768, TEX = 1024;
  function rampTexture() {
    const px = new Uint8Array(4 * TEX);
    for (let i = 0; i < TEX; ++i) {
      const c = i < RAMP ? thicknessColor(i / (RAMP - 1)) : range.above_color;
      px.set([c[0], c[1], c[2], 255], 4 * i);
    }
    const tex = new T.DataTexture(px, TEX, 1, T.RGBAFormat);
    tex.colorSpace = T.SRGBColorSpace;
    tex.magFilter = T.NearestFilter;
    tex.minFilter = T.NearestFilter;
    tex.generateMipmaps = false;
    tex.needsUpdate = true;
    return tex;
  }
  const u = (t, lo, hi) => (isNaN(t) ? 0 : 0.75 * Math.min(Math.max((t - lo) / (hi - lo), 0), 1.3));

  // ---- the scene ----
  const viewer = $('mg-viewer');
  let renderer = null;
  try {
    const canvas = document.createElement('canvas');
    const gl = canvas.getContext('webgl2', { preserveDrawingBuffer: true, antialias: true });
    if (!gl) throw new Error('no WebGL 2');
    renderer = new T.WebGLRenderer({ canvas: canvas, context: gl, preserveDrawingBuffer: true });
  } catch (err) {
    const why = $('mg-no-webgl');
    if (why) { why.hidden = false; why.textContent += ' (' + err.message + ')'; }
    found.webgl = false;
  }
  const center = [0, 0, 0];
  let lo3 = [Infinity, Infinity, Infinity], hi3 = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < NV; ++i) {
    for (let a = 0; a < 3; ++a) {
      lo3[a] = Math.min(lo3[a], P[3 * i + a]);
      hi3[a] = Math.max(hi3[a], P[3 * i + a]);
    }
  }
  if (NV === 0) { lo3 = [0, 0, 0]; hi3 = [0, 0, 0]; }
  for (let a = 0; a < 3; ++a) center[a] = 0.5 * (lo3[a] + hi3[a]);
  const diag = Math.hypot(hi3[0] - lo3[0], hi3[1] - lo3[1], hi3[2] - lo3[2]) || 1;

  let scene, camera, controls, shape, outline, uvs, order, colours;
  const FOV = 30;
  const render = () => { if (renderer) renderer.render(scene, camera); };
  function build() {
    const w = Math.min(viewer.clientWidth || 900, 1200), h = Math.round(w * 0.6);
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setSize(w, h);
    renderer.setClearColor(0xffffff, 1);
    $('mg-canvas-box').appendChild(renderer.domElement);
    scene = new T.Scene();
    camera = new T.PerspectiveCamera(FOV, w / h, diag * 1e-3, diag * 100);
    const zUp = data.up !== 'y';
    camera.up.set(0, zUp ? 0 : 1, zUp ? 1 : 0);
    // The report's oblique view: along (-1, 1, -1) with z up, (-1, -1, -1) with y up.
    const dist = 0.5 * diag / Math.sin(FOV * Math.PI / 360) * 1.05;
    const dir = zUp ? [1, -1, 1] : [1, 1, 1];
    camera.position.set(dir[0], dir[1], dir[2]).normalize().multiplyScalar(dist);
    // 0.3 + 0.7 cos, as the pictures (three.js lights carry a factor pi).
    scene.add(new T.AmbientLight(0xffffff, 0.3 * Math.PI));
    const light = new T.DirectionalLight(0xffffff, 0.7 * Math.PI);
    light.position.set(0, 0, 0);
    light.target.position.set(0, 0, -1);
    camera.add(light);
    camera.add(light.target);
    scene.add(camera);

    const g = new T.BufferGeometry();
    const shownPos = new Float32Array(faces || n === 2 ? E * n * 3 : NV * 3);
    if (faces || n === 2) {
      for (let e = 0; e < E; ++e) {
        for (let k = 0; k < n; ++k) {
          const v = EL[e * n + k];
          for (let a = 0; a < 3; ++a) shownPos[3 * (e * n + k) + a] = P[3 * v + a] - center[a];
        }
      }
    } else {
      for (let i = 0; i < NV; ++i) for (let a = 0; a < 3; ++a) shownPos[3 * i + a] = P[3 * i + a] - center[a];
    }
    g.setAttribute('position', new T.BufferAttribute(shownPos, 3));
    if (n === 2) {  // a 2D curve: coloured segments.
      colours = new Float32Array(E * 6);
      g.setAttribute('color', new T.BufferAttribute(colours, 3));
      shape = new T.LineSegments(g, new T.LineBasicMaterial({ vertexColors: true }));
      scene.add(shape);
    } else {
      uvs = new Float32Array(shownPos.length / 3 * 2);
      g.setAttribute('uv', new T.BufferAttribute(uvs, 2));
      // Valued elements first (the map), then those without a value (grey).
      order = new Uint32Array(E);
      let k = 0;
      for (let e = 0; e < E; ++e) if (valued[e]) order[k++] = e;
      const nValued = k;
      for (let e = 0; e < E; ++e) if (!valued[e]) order[k++] = e;
      if (faces) {
        // Each element on corners of its own, in `order`.
        const pos2 = new Float32Array(E * 9);
        for (let i = 0; i < E; ++i) pos2.set(shownPos.subarray(9 * order[i], 9 * order[i] + 9), 9 * i);
        g.setAttribute('position', new T.BufferAttribute(pos2, 3));
      } else {
        const index = new Uint32Array(E * 3);
        for (let i = 0; i < E; ++i) for (let c = 0; c < 3; ++c) index[3 * i + c] = EL[3 * order[i] + c];
        g.setIndex(new T.BufferAttribute(index, 1));
      }
      g.addGroup(0, 3 * nValued, 0);
      g.addGroup(3 * nValued, 3 * (E - nValued), 1);
      g.computeVertexNormals();
      const grey = new T.Color('rgb(150,150,150)');
      const common = { side: T.DoubleSide, polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 };
      shape = new T.Mesh(g, [new T.MeshLambertMaterial(Object.assign({ map: rampTexture() }, common)),
                             new T.MeshLambertMaterial(Object.assign({ color: grey }, common))]);
      scene.add(shape);
      outline = new T.LineSegments(new T.BufferGeometry(),
                                   new T.LineBasicMaterial({ color: new T.Color('rgb(230,20,20)') }));
      scene.add(outline);
    }
    controls = new T.OrbitControls(camera, renderer.domElement);
    controls.addEventListener('change', render);
  }

  function recolour() {
    const [lo, hi] = colourRange();
    if (n === 2) {
      for (let e = 0; e < E; ++e) {
        for (let k = 0; k < 2; ++k) {
          const t = value(e, k);
          const c = isNaN(value(e, 0)) || isNaN(value(e, 1)) ? [150, 150, 150]
              : t > hi ? range.above_color : thicknessColor((t - lo) / (hi - lo));
          const lin = new T.Color('rgb(' + c.join(',') + ')');
          colours.set([lin.r, lin.g, lin.b], 3 * (2 * e + k));
        }
      }
      shape.geometry.attributes.color.needsUpdate = true;
      return;
    }
    if (faces) {
      for (let i = 0; i < E; ++i) {
        const x = u(V[order[i]], lo, hi);
        for (let c = 0; c < 3; ++c) uvs.set([x, 0.5], 2 * (3 * i + c));
      }
    } else {
      for (let i = 0; i < NV; ++i) uvs.set([u(V[i], lo, hi), 0.5], 2 * i);
    }
    shape.geometry.attributes.uv.needsUpdate = true;
  }

  // The line t = tMin of the interpolated field (face values: the edges
  // between thin elements and the others).
  function reoutline() {
    if (n === 2) return;
    const pts = [];
    const push = (v, w, s) => {  // the point of edge v-w where t = s (s = 1: at v).
      for (let a = 0; a < 3; ++a) pts.push(P[3 * v + a] + (P[3 * w + a] - P[3 * v + a]) * s - center[a]);
    };
    if (faces) {
      const edges = new Map();
      for (let e = 0; e < E; ++e) {
        if (!valued[e] || !(V[e] < tMin)) continue;
        for (let k = 0; k < 3; ++k) {
          const a = EL[3 * e + k], b = EL[3 * e + (k + 1) % 3];
          const key = Math.min(a, b) * NV + Math.max(a, b);
          edges.set(key, (edges.get(key) || 0) + 1);
        }
      }
      for (const [key, count] of edges) {
        if (count !== 1) continue;
        const a = Math.floor(key / NV), b = key - a * NV;
        push(a, b, 0);
        push(b, a, 0);
      }
    } else {
      for (let e = 0; e < E; ++e) {
        if (!valued[e]) continue;
        const crossings = [];
        for (let k = 0; k < 3; ++k) {
          const a = EL[3 * e + k], b = EL[3 * e + (k + 1) % 3];
          const ta = V[a], tb = V[b];
          if ((ta < tMin) !== (tb < tMin)) crossings.push([a, b, (tMin - ta) / (tb - ta)]);
        }
        if (crossings.length === 2) for (const [a, b, s] of crossings) push(a, b, s);
      }
    }
    outline.geometry.dispose();
    outline.geometry = new T.BufferGeometry();
    outline.geometry.setAttribute('position', new T.Float32BufferAttribute(pts, 3));
  }

  function setTMin(t) {
    if (!(t > 0) || !isFinite(t)) return;
    tMin = t;
    updateNumbers(true);
    if (renderer) {
      recolour();
      reoutline();
      render();
    }
    const slider = $('mg-tmin');
    if (slider && Number(slider.value) !== t) slider.value = String(t);
  }

  // ---- read-outs ----
  const readout = $('mg-readout');
  const fmtP = (x, y, z) => '(' + fmtG(x + center[0], 6) + ', ' + fmtG(y + center[1], 6) + ', ' + fmtG(z + center[2], 6) + ')';
  function pick(event) {
    if (n === 2) return;
    const box = renderer.domElement.getBoundingClientRect();
    const ndc = new T.Vector2(((event.clientX - box.left) / box.width) * 2 - 1,
                              -((event.clientY - box.top) / box.height) * 2 + 1);
    const ray = new T.Raycaster();
    ray.setFromCamera(ndc, camera);
    const hit = ray.intersectObject(shape, false)[0];
    if (!hit) { readout.textContent = 'Point at the mesh to read its thickness.'; return; }
    const e = order[hit.faceIndex];
    const p = hit.point;
    const shown = data.shown.decimated ? ' (simplified view)' : '';
    if (!valued[e]) {
      readout.textContent = 'no value at ' + fmtP(p.x, p.y, p.z);
    } else if (faces) {
      readout.textContent = 'face value ' + fmtG(V[e], 6) + ' at ' + fmtP(p.x, p.y, p.z) + shown;
    } else {
      // The nearest corner, and the interpolated value at the point.
      let best = -1, bestD = Infinity;
      const c = [hit.face.a, hit.face.b, hit.face.c];
      for (const v of c) {
        const d = Math.hypot(P[3 * v] - center[0] - p.x, P[3 * v + 1] - center[1] - p.y, P[3 * v + 2] - center[2] - p.z);
        if (d < bestD) { bestD = d; best = v; }
      }
      const bc = new T.Vector3();
      const tri = c.map((v) => new T.Vector3(P[3 * v] - center[0], P[3 * v + 1] - center[1], P[3 * v + 2] - center[2]));
      // Barycentric weights of p.
      const v0 = tri[1].clone().sub(tri[0]), v1 = tri[2].clone().sub(tri[0]), v2 = p.clone().sub(tri[0]);
      const d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
      const den = d00 * d11 - d01 * d01;
      bc.y = den ? (d11 * d20 - d01 * d21) / den : 0;
      bc.z = den ? (d00 * d21 - d01 * d20) / den : 0;
      bc.x = 1 - bc.y - bc.z;
      const here = bc.x * V[c[0]] + bc.y * V[c[1]] + bc.z * V[c[2]];
      readout.textContent = 'thickness ' + fmtG(here, 6) + ' at ' + fmtP(p.x, p.y, p.z) + '; vertex ' + best +
          shown + ': ' + fmtG(V[best], 6) + ' at ' +
          fmtP(P[3 * best] - center[0], P[3 * best + 1] - center[1], P[3 * best + 2] - center[2]);
    }
  }

  // ---- regions: fly the camera ----
  let flight = null;
  function fly(index, instant) {
    const r = data.regions[index];
    if (!r || !renderer) return;
    for (const row of document.querySelectorAll('tr[data-region]')) {
      row.classList.toggle('mg-current', Number(row.getAttribute('data-region')) === index);
    }
    const target = new T.Vector3(r.centroid[0] - center[0], r.centroid[1] - center[1], r.centroid[2] - center[2]);
    const size = Math.max(Math.hypot(r.box_max[0] - r.box_min[0], r.box_max[1] - r.box_min[1],
                                     r.box_max[2] - r.box_min[2]), 0.05 * diag);
    const dir = camera.position.clone().sub(controls.target).normalize();
    const to = target.clone().add(dir.multiplyScalar(size / Math.sin(FOV * Math.PI / 360)));
    const fromPos = camera.position.clone(), fromTarget = controls.target.clone();
    const start = performance.now(), ms = instant ? 0 : 600;
    const step = (now) => {
      const s = ms ? Math.min((now - start) / ms, 1) : 1;
      const k = s * s * (3 - 2 * s);
      camera.position.lerpVectors(fromPos, to, k);
      controls.target.lerpVectors(fromTarget, target, k);
      controls.update();
      render();
      flight = s < 1 ? requestAnimationFrame(step) : null;
    };
    if (flight) cancelAnimationFrame(flight);
    step(start);
    found.flown_to = [target.x + center[0], target.y + center[1], target.z + center[2]];
  }

  // ---- wiring ----
  updateNumbers(false);
  const shownNote = $('mg-shown');
  if (shownNote) {
    const sh = data.shown;
    shownNote.textContent = sh.decimated || sh.quantised
        ? 'This mesh has ' + data.mesh.vertices + ' vertices, more than the ' + sh.limit +
          ' the page sends in full: the view shows a simplified copy of ' + sh.vertices +
          ' vertices (vertices merged on a grid, positions quantised to 16 bits per axis, values as 32-bit floats), ' +
          'so the live numbers are approximate; those of the report (at t_min = ' + fmtG(data.t_min, 6) +
          ') are exact.'
        : 'The view shows all ' + data.mesh.vertices + ' vertices; the live numbers are exact.';
  }
  if (renderer) {
    viewer.hidden = false;
    build();
    recolour();
    reoutline();
    render();
    const slider = $('mg-tmin');
    slider.max = String(3 * data.t_min);
    slider.step = 'any';
    slider.value = String(data.t_min);
    $('mg-tmin-value').value = String(data.t_min);
    slider.addEventListener('input', () => setTMin(Number(slider.value)));
    $('mg-tmin-value').addEventListener('change', (ev) => setTMin(Number(ev.target.value)));
    let pending = null;
    renderer.domElement.addEventListener('pointermove', (ev) => {
      if (data.shown.elements > 500000) return;  // click instead: ray casts cost.
      if (pending) return;
      pending = requestAnimationFrame(() => { pending = null; pick(ev); });
    });
    renderer.domElement.addEventListener('click', pick);
    for (const row of document.querySelectorAll('tr[data-region]')) {
      row.addEventListener('click', () => fly(Number(row.getAttribute('data-region')), false));
      row.title = 'show this region in the view';
    }
    window.addEventListener('resize', () => {
      const w = Math.min(viewer.clientWidth || 900, 1200), h = Math.round(w * 0.6);
      renderer.setSize(w, h);
      camera.aspect = w / h;
      camera.updateProjectionMatrix();
      render();
    });
  }

  // ---- self-test ----
  const m = /selftest=([^&]*)/.exec(location.hash);
  if (m) {
    const result = { webgl: !!renderer, steps: [] };
    for (const t of m[1].split(',').map(Number)) {
      setTMin(t);
      result.steps.push({ t_min: tMin, thin_fraction: state.thin_fraction, thin_area: state.thin_area,
                          total_area: state.total_area, bands: Object.assign({}, state.bands),
                          answer: answer ? answer.textContent : '',
                          outline_points: outline ? outline.geometry.attributes.position.count : 0 });
    }
    const row = document.querySelector('tr[data-region="0"]');
    if (row) {
      row.dispatchEvent(new MouseEvent('click', { bubbles: true }));
      fly(0, true);
      result.clicked_row = row.classList.contains('mg-current');
      result.flown_to = found.flown_to;
      result.camera_target = controls ? controls.target.toArray().map((x, a) => x + center[a]) : null;
    }
    if (renderer) {
      render();
      const gl = renderer.getContext();
      const w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
      const px = new Uint8Array(4 * w * h);
      gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
      let painted = 0;
      const colours = new Set();
      for (let i = 0; i < w * h; ++i) {
        const r = px[4 * i], g = px[4 * i + 1], b = px[4 * i + 2];
        if (r !== 255 || g !== 255 || b !== 255) ++painted;
        colours.add((r << 16) | (g << 8) | b);
      }
      result.canvas = { width: w, height: h, painted: painted, colours: colours.size };
    }
    result.errors = found.errors;
    const pre = document.createElement('pre');
    pre.id = 'mg-selftest';
    pre.textContent = JSON.stringify(result);
    document.body.appendChild(pre);
    document.title = 'selftest done';
  }
})();
