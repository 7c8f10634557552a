// endoloc run viewer: a 3-D view, a frame scrubber and the error along the pass, drawn on
// 2-D canvases with a hand-written perspective projection. Lengths in mm, world frame, poses
// T_wc (camera-to-world), camera axes x right, y down, z forward. Live (`D.live`), the page
// starts without frames and appends each one the server's event stream brings.
(function () {
  'use strict';
  var D = JSON.parse(document.getElementById('viewer-data').textContent);
  var N = D.frames;
  var LIVE = !!D.live;
  var STATUS = ['refined', 'init_only', 'rejected'];
  var STATUS_COLOUR = ['#4cd964', '#ff9f0a', '#ff453a'];
  var body = document.body;
  var $ = function (id) { return document.getElementById(id); };

  // ---- geometry -------------------------------------------------------------------------
  function rotation(q) { // [qx qy qz qw] -> row-major 3x3
    var x = q[0], y = q[1], z = q[2], w = q[3];
    return [
      1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
      2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
      2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)
    ];
  }
  function camToWorld(p, c) { // p: pose7, c: camera point -> world point
    var R = rotation(p.slice(3));
    return [
      R[0] * c[0] + R[1] * c[1] + R[2] * c[2] + p[0],
      R[3] * c[0] + R[4] * c[1] + R[5] * c[2] + p[1],
      R[6] * c[0] + R[7] * c[1] + R[8] * c[2] + p[2]
    ];
  }
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

  // Principal axes of the scene (Jacobi on the 3x3 covariance): the view starts looking
  // along the axis of least spread, so the whole pass is in sight.
  function principalAxes(xyz) {
    var n = xyz.length / 3, m = [0, 0, 0], i, j, k;
    if (n === 0) return { centre: [0, 0, 0], axes: [[1, 0, 0], [0, 1, 0], [0, 0, 1]], radius: 100 };
    for (i = 0; i < n; i++) for (k = 0; k < 3; k++) m[k] += xyz[3 * i + k] / n;
    var C = [[0, 0, 0], [0, 0, 0], [0, 0, 0]], r2 = 0;
    for (i = 0; i < n; i++) {
      var d = [xyz[3 * i] - m[0], xyz[3 * i + 1] - m[1], xyz[3 * i + 2] - m[2]];
      r2 = Math.max(r2, dot(d, d));
      for (j = 0; j < 3; j++) for (k = 0; k < 3; k++) C[j][k] += d[j] * d[k] / n;
    }
    var V = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
    for (var sweep = 0; sweep < 30; sweep++) {
      for (var p = 0; p < 2; p++) for (var q = p + 1; q < 3; q++) {
        if (Math.abs(C[p][q]) < 1e-12) continue;
        var th = 0.5 * Math.atan2(2 * C[p][q], C[q][q] - C[p][p]);
        var c = Math.cos(th), s = Math.sin(th);
        for (k = 0; k < 3; k++) { // C <- C J
          var a = C[k][p], b = C[k][q];
          C[k][p] = c * a - s * b; C[k][q] = s * a + c * b;
        }
        for (k = 0; k < 3; k++) { // C <- J^T C
          var a2 = C[p][k], b2 = C[q][k];
          C[p][k] = c * a2 - s * b2; C[q][k] = s * a2 + c * b2;
        }
        for (k = 0; k < 3; k++) {
          var a3 = V[k][p], b3 = V[k][q];
          V[k][p] = c * a3 - s * b3; V[k][q] = s * a3 + c * b3;
        }
      }
    }
    var order = [0, 1, 2].sort(function (a, b) { return C[b][b] - C[a][a]; });
    var axes = order.map(function (o) { return [V[0][o], V[1][o], V[2][o]]; });
    var e3 = [ // right-handed
      axes[0][1] * axes[1][2] - axes[0][2] * axes[1][1],
      axes[0][2] * axes[1][0] - axes[0][0] * axes[1][2],
      axes[0][0] * axes[1][1] - axes[0][1] * axes[1][0]
    ];
    axes[2] = e3;
    return { centre: m, axes: axes, radius: Math.max(Math.sqrt(r2), 1) };
  }

  var sceneXyz = D.train.slice();
  (D.gt || []).forEach(function (p) { sceneXyz.push(p[0], p[1], p[2]); });
  D.est.forEach(function (p) { if (p) sceneXyz.push(p[0], p[1], p[2]); });
  if (sceneXyz.length === 0) sceneXyz = D.points.slice();
  var scene = principalAxes(sceneXyz);

  // ---- colours ----------------------------------------------------------------------------
  function zoneColour(z) {
    var h = ((z * 0.618034) % 1) * 360;
    return 'hsl(' + h.toFixed(0) + ',75%,58%)';
  }
  var errScale = 1;
  if (D.pos_err) {
    var errs = D.pos_err.filter(function (e) { return e !== null; }).sort(function (a, b) { return a - b; });
    errScale = errs.length ? Math.max(errs[Math.floor(0.95 * (errs.length - 1))], 1e-3) : 1;
  }
  function errorColour(e) { // green -> yellow -> red over [0, errScale]
    var t = Math.min(Math.max(e / errScale, 0), 1);
    var r = t < 0.5 ? Math.round(510 * t) : 255;
    var g = t < 0.5 ? 220 : Math.round(220 * (2 - 2 * t));
    return 'rgb(' + r + ',' + g + ',40)';
  }

  // ---- state -------------------------------------------------------------------------------
  var cur = 0;
  var view = {
    yaw: 0, el: Math.PI / 2 * 0.75, dist: 2.6 * scene.radius,
    target: scene.centre.slice()
  };
  var drawnPoints = 0, reprojected = 0, matched = 0;
  var scopeMoves = 0, lastScope = null;

  // ---- 3-D view ---------------------------------------------------------------------------
  var c3 = $('view3d'), g3 = c3.getContext('2d');
  function projector() {
    var ax = scene.axes, cy = Math.cos(view.yaw), sy = Math.sin(view.yaw);
    var ce = Math.cos(view.el), se = Math.sin(view.el);
    var F = 0.5 * c3.height / Math.tan(0.5 * 40 * Math.PI / 180);
    var W2 = c3.width / 2, H2 = c3.height / 2, t = view.target, dist = view.dist;
    var near = dist * 0.02;
    return function (x, y, z, out) {
      var qx = x - t[0], qy = y - t[1], qz = z - t[2];
      var a1 = qx * ax[0][0] + qy * ax[0][1] + qz * ax[0][2];
      var a2 = qx * ax[1][0] + qy * ax[1][1] + qz * ax[1][2];
      var a3 = qx * ax[2][0] + qy * ax[2][1] + qz * ax[2][2];
      var bx = a1 * cy - a2 * sy, by = a1 * sy + a2 * cy, bz = a3;
      var depth = by * ce - bz * se + dist;
      if (depth < near) return false;
      var sx = bx, su = by * se + bz * ce;
      out[0] = W2 + F * sx / depth;
      out[1] = H2 - F * su / depth;
      return true;
    };
  }
  function currentPose() {
    return D.est[cur] || (D.gt ? D.gt[cur] : null);
  }
  function polyline(P, xyz, stride, colour, width) {
    var s = [0, 0], started = false;
    g3.strokeStyle = colour; g3.lineWidth = width; g3.beginPath();
    for (var i = 0; i + 2 < xyz.length; i += stride) {
      if (P(xyz[i], xyz[i + 1], xyz[i + 2], s)) {
        if (started) g3.lineTo(s[0], s[1]); else g3.moveTo(s[0], s[1]);
        started = true;
      } else started = false;
    }
    g3.stroke();
  }
  function frustum(P, pose, colour) {
    var cam = D.camera, d = 0.07 * scene.radius;
    var corners = [[0, 0], [cam.width, 0], [cam.width, cam.height], [0, cam.height]].map(function (uv) {
      return camToWorld(pose, [(uv[0] - cam.cx) / cam.fx * d, (uv[1] - cam.cy) / cam.fy * d, d]);
    });
    var apex = [0, 0], s = corners.map(function () { return [0, 0]; }), ok = P(pose[0], pose[1], pose[2], apex);
    for (var i = 0; i < 4; i++) ok = P(corners[i][0], corners[i][1], corners[i][2], s[i]) && ok;
    if (!ok) return;
    g3.strokeStyle = colour; g3.lineWidth = 1.5; g3.beginPath();
    for (i = 0; i < 4; i++) { g3.moveTo(apex[0], apex[1]); g3.lineTo(s[i][0], s[i][1]); }
    g3.moveTo(s[3][0], s[3][1]);
    for (i = 0; i < 4; i++) g3.lineTo(s[i][0], s[i][1]);
    g3.stroke();
    // the image's top edge (y = 0) thicker: which way is up for the scope
    g3.lineWidth = 4; g3.beginPath(); g3.moveTo(s[0][0], s[0][1]); g3.lineTo(s[1][0], s[1][1]); g3.stroke();
  }
  function draw3d() {
    if ($('follow').checked) {
      var p = currentPose();
      if (p) view.target = [p[0], p[1], p[2]];
    }
    var P = projector(), s = [0, 0], i, z;
    g3.fillStyle = '#0d0e10'; g3.fillRect(0, 0, c3.width, c3.height);
    drawnPoints = 0;
    if (D.wall && $('showWall').checked) {
      D.wall.forEach(function (ring) { polyline(P, ring.concat(ring.slice(0, 3)), 3, '#3b4350', 1); });
    }
    if ($('showPoints').checked) {
      for (z = 0; z < D.zone_points.length; z++) {
        var r = D.zone_points[z];
        if (r[1] <= r[0]) continue;
        g3.fillStyle = zoneColour(z);
        g3.globalAlpha = 0.55;
        for (i = r[0]; i < r[1]; i++) {
          if (P(D.points[3 * i], D.points[3 * i + 1], D.points[3 * i + 2], s)) {
            g3.fillRect(s[0] - 1, s[1] - 1, 2, 2);
            drawnPoints++;
          }
        }
      }
      g3.globalAlpha = 1;
    }
    if ($('showTrain').checked && D.train.length) polyline(P, D.train, 3, '#9aa0a8', 1.5);
    if ($('showGt').checked && D.gt) {
      var flat = [];
      D.gt.forEach(function (p) { flat.push(p[0], p[1], p[2]); });
      polyline(P, flat, 3, '#4a9eff', 1.5);
    }
    if ($('showEst').checked) {
      var byErr = $('byError').checked && D.pos_err;
      for (i = 0; i < N; i++) {
        var e = D.est[i];
        if (!e || !P(e[0], e[1], e[2], s)) continue;
        g3.fillStyle = byErr ? (D.pos_err[i] === null ? '#888' : errorColour(D.pos_err[i])) : STATUS_COLOUR[D.status[i]];
        g3.fillRect(s[0] - 1.5, s[1] - 1.5, 3, 3);
      }
    }
    if (D.gt && D.gt[cur]) frustum(P, D.gt[cur], '#4a9eff');
    if (D.est[cur]) {
      frustum(P, D.est[cur], '#ffffff');
      var apex = [0, 0];
      if (P(D.est[cur][0], D.est[cur][1], D.est[cur][2], apex)) {
        var key = apex[0].toFixed(1) + ',' + apex[1].toFixed(1);
        if (key !== lastScope) { scopeMoves++; lastScope = key; }
      }
    }
  }

  // orbit and zoom
  var drag = null;
  c3.addEventListener('mousedown', function (ev) { drag = [ev.clientX, ev.clientY]; c3.style.cursor = 'grabbing'; });
  window.addEventListener('mouseup', function () { drag = null; c3.style.cursor = 'grab'; });
  window.addEventListener('mousemove', function (ev) {
    if (!drag) return;
    view.yaw += (ev.clientX - drag[0]) * 0.008;
    view.el = Math.max(-Math.PI / 2, Math.min(Math.PI / 2, view.el + (ev.clientY - drag[1]) * 0.008));
    drag = [ev.clientX, ev.clientY];
    draw3d();
  });
  c3.addEventListener('wheel', function (ev) {
    ev.preventDefault();
    view.dist *= Math.exp(0.0015 * ev.deltaY);
    view.dist = Math.max(view.dist, 0.01 * scene.radius);
    draw3d();
  }, { passive: false });
  c3.addEventListener('dblclick', function () {
    view.target = scene.centre.slice(); view.dist = 2.6 * scene.radius; draw3d();
  });

  // ---- thumbnail and its reprojected map ----------------------------------------------------
  var ct = $('thumb'), gt2 = ct.getContext('2d');
  var scale = Math.max(1, Math.floor(320 / D.thumb.width));
  ct.width = D.thumb.width * scale; ct.height = D.thumb.height * scale;
  var imgCache = {};
  function reprojection(i) { // pixel positions on the thumbnail canvas
    var pose = D.est[i], z = D.zone[i], out = [];
    if (!pose || z === null || z < 0 || z >= D.zone_points.length) return out;
    var R = rotation(pose.slice(3)), cam = D.camera, k = ct.width / cam.width, r = D.zone_points[z];
    for (var j = r[0]; j < r[1]; j++) {
      var dx = D.points[3 * j] - pose[0], dy = D.points[3 * j + 1] - pose[1], dz = D.points[3 * j + 2] - pose[2];
      // p_cam = R^T (p_world - t)
      var x = R[0] * dx + R[3] * dy + R[6] * dz;
      var y = R[1] * dx + R[4] * dy + R[7] * dz;
      var zc = R[2] * dx + R[5] * dy + R[8] * dz;
      if (zc <= 1e-6) continue;
      var xy = distort(x / zc, y / zc);
      var u = (cam.fx * xy[0] + cam.cx + 0.5) * k - 0.5, v = (cam.fy * xy[1] + cam.cy + 0.5) * k - 0.5;
      if (u >= 0 && v >= 0 && u < ct.width && v < ct.height) out.push([u, v]);
    }
    return out;
  }
  function distort(x, y) { // normalized pinhole coordinates -> distorted (OpenCV models)
    var d = D.camera.distortion;
    if (!d) return [x, y];
    var c = d[1];
    if (d[0] === 'fisheye') {
      var r = Math.sqrt(x * x + y * y);
      if (r < 1e-12) return [x, y];
      var th = Math.atan(r), t2 = th * th;
      var s = th * (1 + t2 * (c[0] + t2 * (c[1] + t2 * (c[2] + t2 * c[3])))) / r;
      return [x * s, y * s];
    }
    var r2 = x * x + y * y, radial = 1 + r2 * (c[0] + r2 * (c[1] + r2 * c[4]));
    return [x * radial + 2 * c[2] * x * y + c[3] * (r2 + 2 * x * x),
      y * radial + c[2] * (r2 + 2 * y * y) + 2 * c[3] * x * y];
  }
  function keypoints(i) { // the frame's inlier keypoints on the thumbnail canvas
    var out = [], kp = D.keypoints ? D.keypoints[i] : null, k = ct.width / D.camera.width;
    if (!kp) return out;
    for (var j = 0; j + 1 < kp.length; j += 2) out.push([(kp[j] + 0.5) * k - 0.5, (kp[j + 1] + 0.5) * k - 0.5]);
    return out;
  }
  function drawThumb() {
    var i = cur, pts = reprojection(i), kps = keypoints(i);
    reprojected = pts.length;
    matched = kps.length;
    var img = imgCache[i];
    function paint() {
      if (i !== cur) return;
      gt2.fillStyle = '#000'; gt2.fillRect(0, 0, ct.width, ct.height);
      if (img.complete && img.naturalWidth) gt2.drawImage(img, 0, 0, ct.width, ct.height);
      gt2.fillStyle = '#00ff88';
      pts.forEach(function (p) { gt2.fillRect(p[0] - 1.5, p[1] - 1.5, 3, 3); });
      gt2.strokeStyle = '#ffd23f'; gt2.lineWidth = 1;
      kps.forEach(function (p) { gt2.beginPath(); gt2.arc(p[0], p[1], 3.5, 0, 2 * Math.PI); gt2.stroke(); });
    }
    if (!img && D.images[i]) {
      img = new Image();
      imgCache[i] = img;
      img.onload = paint;
      img.src = 'data:' + D.image_mime + ';base64,' + D.images[i];
    }
    if (img) paint();
    else { gt2.fillStyle = '#000'; gt2.fillRect(0, 0, ct.width, ct.height); }
  }

  // ---- frame information ------------------------------------------------------------------
  function fmt(x, digits, unit) { return x === null || x === undefined ? '—' : x.toFixed(digits) + (unit || ''); }
  function showInfo() {
    var i = cur, st = STATUS[D.status[i]], e = D.est[i], g = D.gt ? D.gt[i] : null;
    var rows = [
      ['frame', (D.frame_index ? D.frame_index[i] + ' of the video, at ' + fmt(D.time_s[i], 2, ' s') : i + ' of ' + N)],
      ['zone', D.zone[i] === null ? '—' : D.zone[i] + (D.zone_score[i] === null ? '' : ' (score ' + D.zone_score[i].toFixed(3) + ')')],
      ['status', '<span class="' + st + '">' + st + '</span>'],
      ['reason', D.reason[i] || '—'],
      ['inliers', D.inliers[i] === null ? '—' : String(D.inliers[i])],
      ['reprojection RMS', fmt(D.rms[i], 2, ' px')],
      ['time', fmt(D.time_ms[i], 1, ' ms')],
      ['map points shown', String(reprojected)],
      ['matched keypoints', D.keypoints ? String(matched) : '—']
    ];
    if (D.along) {
      rows.splice(1, 0, ['along the colon', D.along[i] === null ? '—' : (D.along[i] / 10).toFixed(1) + ' cm from ' + (D.along_from || 'the start')],
        ['section', D.section[i] || '—']);
      if (D.std_mm) rows.push(['position std', fmt(D.std_mm[i], 2, ' mm')]);
      if (D.latency_ms) rows.push(['frame to pose', fmt(D.latency_ms[i], 1, ' ms')]);
    }
    if (D.pos_err) {
      rows.push(['position error', fmt(D.pos_err[i], 2, ' mm')]);
      rows.push(['orientation error', fmt(D.rot_err[i], 2, '°')]);
    }
    rows.push(['estimate (mm)', e ? e.slice(0, 3).map(function (v) { return v.toFixed(1); }).join(', ') : '—']);
    if (g) rows.push(['truth (mm)', g.slice(0, 3).map(function (v) { return v.toFixed(1); }).join(', ')]);
    $('info').innerHTML = rows.map(function (r) { return '<tr><td>' + r[0] + '</td><td>' + r[1] + '</td></tr>'; }).join('');
    $('frameLabel').textContent = 'frame ' + i + ' / ' + (N - 1);
  }

  // ---- error (or zone) along the pass -------------------------------------------------------
  var cp = $('plot'), gp = cp.getContext('2d');
  var PAD = { l: 48, r: 10, t: 10, b: 24 };
  var plotMax = 1;
  if (D.pos_err) {
    var pe = D.pos_err.filter(function (e) { return e !== null; }).sort(function (a, b) { return a - b; });
    plotMax = pe.length ? Math.max(pe[Math.floor(0.98 * (pe.length - 1))] * 1.1, 1e-3) : 1;
  } else {
    plotMax = Math.max(D.zones, 1);
  }
  function plotX(i) { return PAD.l + (cp.width - PAD.l - PAD.r) * (N > 1 ? i / (N - 1) : 0.5); }
  function plotY(v) { return cp.height - PAD.b - (cp.height - PAD.t - PAD.b) * Math.min(v / plotMax, 1); }
  function drawPlot() {
    gp.fillStyle = '#0d0e10'; gp.fillRect(0, 0, cp.width, cp.height);
    gp.strokeStyle = '#444'; gp.lineWidth = 1; gp.beginPath();
    gp.moveTo(PAD.l, PAD.t); gp.lineTo(PAD.l, cp.height - PAD.b); gp.lineTo(cp.width - PAD.r, cp.height - PAD.b); gp.stroke();
    gp.fillStyle = '#aaa'; gp.font = '11px sans-serif';
    gp.fillText(D.pos_err ? plotMax.toFixed(1) + ' mm' : 'zone ' + plotMax, 2, PAD.t + 8);
    gp.fillText('0', PAD.l - 12, cp.height - PAD.b);
    for (var k = 0; k <= 10 && N > 1; k++) {
      var f = Math.round(k * (N - 1) / 10), label = String(f);
      gp.fillText(label, plotX(f) - gp.measureText(label).width / 2, cp.height - 5);
    }
    for (var i = 0; i < N; i++) {
      var v = D.pos_err ? D.pos_err[i] : D.zone[i];
      gp.fillStyle = STATUS_COLOUR[D.status[i]];
      if (v === null || v === undefined) {
        gp.fillRect(plotX(i) - 0.5, cp.height - PAD.b + 1, 1, 4);
      } else {
        gp.fillRect(plotX(i) - 1, plotY(v) - 1, 2, 2);
      }
    }
    gp.strokeStyle = '#fff'; gp.beginPath(); gp.moveTo(plotX(cur), PAD.t); gp.lineTo(plotX(cur), cp.height - PAD.b); gp.stroke();
    var caption = D.pos_err ? 'position error along the pass, by frame (click: go to frame)' : 'zone along the pass, by frame (no ground truth; click: go to frame)';
    var cw = gp.measureText(caption).width;
    gp.fillStyle = 'rgba(13,14,16,0.8)'; gp.fillRect(cp.width - PAD.r - cw - 4, PAD.t - 2, cw + 4, 14);
    gp.fillStyle = '#aaa'; gp.fillText(caption, cp.width - PAD.r - cw - 2, PAD.t + 8);
  }
  cp.addEventListener('click', function (ev) {
    var rect = cp.getBoundingClientRect();
    var x = (ev.clientX - rect.left) * cp.width / rect.width;
    var f = Math.round((x - PAD.l) / (cp.width - PAD.l - PAD.r) * (N - 1));
    setFrame(Math.max(0, Math.min(N - 1, f)));
  });

  // ---- legend, controls, playback ---------------------------------------------------------
  function legend() {
    var items = [['#9aa0a8', 'training pass'], ['#4a9eff', 'ground truth / true scope']];
    if (!D.gt) items.pop();
    if ($('byError').checked && D.pos_err) {
      items.push([errorColour(0), 'error 0'], [errorColour(errScale / 2), (errScale / 2).toFixed(1) + ' mm'], [errorColour(errScale), '≥ ' + errScale.toFixed(1) + ' mm']);
    } else {
      items.push([STATUS_COLOUR[0], 'refined'], [STATUS_COLOUR[1], 'init_only'], [STATUS_COLOUR[2], 'rejected']);
    }
    items.push(['#ffffff', 'estimated scope']);
    $('legend3d').innerHTML = items.map(function (it) {
      return '<span><i class="sw" style="background:' + it[0] + '"></i>' + it[1] + '</span>';
    }).join('') + '<span>points: map, by zone · drag: orbit · wheel: zoom · double-click: reset</span>';
  }
  function mark() {
    body.setAttribute('data-frame', String(cur));
    body.setAttribute('data-drawn-points', String(drawnPoints));
    body.setAttribute('data-reprojected', String(reprojected));
    body.setAttribute('data-keypoints', String(matched));
    body.setAttribute('data-zone', String(D.zone[cur]));
    body.setAttribute('data-status', STATUS[D.status[cur]]);
    body.setAttribute('data-errors', String(window.viewerErrors || 0));
    body.setAttribute('data-frames', String(N));
    body.setAttribute('data-scope-moves', String(scopeMoves));
    if (D.along && N > 0 && D.along[cur] !== null) {
      body.setAttribute('data-along', D.along[cur].toFixed(1));
      if (!body.hasAttribute('data-along-first')) body.setAttribute('data-along-first', D.along[cur].toFixed(1));
    }
  }
  function drawAll() {
    draw3d(); drawThumb(); showInfo(); drawPlot(); mark();
  }
  function setFrame(i) {
    cur = i;
    $('scrub').value = String(i);
    drawAll();
  }
  $('scrub').max = String(Math.max(N - 1, 0));
  $('scrub').addEventListener('input', function () { setFrame(parseInt(this.value, 10)); });
  if (!D.wall) $('showWall').parentNode.style.display = 'none';
  ['showWall', 'showTrain', 'showPoints', 'showGt', 'showEst', 'follow'].forEach(function (id) {
    $(id).addEventListener('change', draw3d);
  });
  $('byError').addEventListener('change', function () { legend(); draw3d(); });
  if (!D.pos_err) { $('byError').disabled = true; $('showGt').disabled = true; }
  var timer = null;
  $('play').addEventListener('click', function () {
    if (timer) { clearInterval(timer); timer = null; this.textContent = 'play'; return; }
    if (cur >= N - 1) setFrame(0);
    this.textContent = 'pause';
    var button = this;
    timer = setInterval(function () {
      if (cur >= N - 1) { clearInterval(timer); timer = null; button.textContent = 'play'; return; }
      setFrame(cur + 1);
    }, 66);
  });
  window.addEventListener('keydown', function (ev) {
    if (ev.target && ev.target.tagName === 'INPUT' && ev.target.type === 'range') return;
    if (ev.key === 'ArrowRight') setFrame(Math.min(N - 1, cur + 1));
    if (ev.key === 'ArrowLeft') setFrame(Math.max(0, cur - 1));
  });
  function frameFromHash() {
    var m = /frame=(\d+)/.exec(location.hash);
    return m ? Math.max(0, Math.min(N - 1, parseInt(m[1], 10))) : 0;
  }
  // `#frame=N` in the address opens frame N, through the scrubber as a user would move it.
  function openFromHash() {
    $('scrub').value = String(frameFromHash());
    $('scrub').dispatchEvent(new Event('input'));
  }
  window.addEventListener('hashchange', openFromHash);

  var counts = [0, 0, 0];
  D.status.forEach(function (s) { counts[s]++; });
  function summary() {
    $('summary').textContent = (LIVE ? (liveState + ' · ') : '') + N + ' frames: ' + counts[0] + ' refined, ' + counts[1] +
      ' init_only, ' + counts[2] + ' rejected; ' + D.zones + ' zones, ' + D.points.length / 3 + ' map points' +
      (D.gt ? '' : '; no ground truth');
  }
  $('title').textContent = D.title;
  legend();

  // ---- live: frames from the server's event stream ------------------------------------------
  // Each event is one frame (`f`: its pose7, status, zone, along the colon, thumbnail);
  // `snapshot` holds every frame so far for a viewer that connects mid-stream (thumbnails only
  // for the newest), `end` says the stream is over.
  var liveState = 'connecting', snapshot = -1, pending = false;
  var FIELDS = ['est', 'zone', 'zone_score', 'status', 'reason', 'inliers', 'rms', 'time_ms', 'images',
    'along', 'section', 'std_mm', 'latency_ms', 'frame_index', 'time_s', 'keypoints'];
  function append(f) {
    D.est.push(f.est); D.zone.push(f.zone); D.zone_score.push(f.zone_score); D.status.push(f.status);
    D.reason.push(f.reason); D.inliers.push(f.inliers); D.rms.push(f.rms); D.time_ms.push(f.time_ms);
    D.images.push(f.image || null); D.along.push(f.along); D.section.push(f.section); D.std_mm.push(f.std_mm);
    D.latency_ms.push(f.latency_ms); D.frame_index.push(f.frame); D.time_s.push(f.t); D.keypoints.push(f.keypoints);
    counts[f.status]++;
    N = D.est.length;
    // thumbnails of all but the last few hundred frames are let go
    if (N > 300) { D.images[N - 301] = null; delete imgCache[N - 301]; }
  }
  function redraw() {
    pending = false;
    $('scrub').max = String(Math.max(N - 1, 0));
    if ($('followLive').checked && N > 0) { cur = N - 1; $('scrub').value = String(cur); }
    summary();
    if (N > 0) drawAll(); else mark();
    body.setAttribute('data-live', liveState);
    body.setAttribute('data-snapshot', String(snapshot));
  }
  function later() { if (!pending) { pending = true; requestAnimationFrame(redraw); } }
  if (LIVE) {
    FIELDS.forEach(function (k) { if (!D[k]) D[k] = []; });
    $('liveBar').style.display = '';
    var es = new EventSource('events');
    es.addEventListener('snapshot', function (ev) {
      var frames = JSON.parse(ev.data);
      snapshot = frames.length;
      frames.forEach(append);
      liveState = 'live';
      later();
    });
    // Each frame drawn as it comes (the scope moves with the video), not batched.
    es.onmessage = function (ev) {
      append(JSON.parse(ev.data));
      liveState = 'live';
      redraw();
    };
    es.addEventListener('end', function (ev) {
      liveState = 'ended: ' + ev.data;
      es.close();
      redraw();
    });
    es.onerror = function () { if (liveState.indexOf('ended') !== 0) { liveState = 'reconnecting'; later(); } };
    summary();
    mark();
    body.setAttribute('data-live', liveState);
  } else {
    summary();
    if (N > 0) openFromHash(); else mark();
  }
})();
