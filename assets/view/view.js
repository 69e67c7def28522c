// spherestep view: the script of the page written by `spherestep view`.
// A small canvas 2-D renderer of the 3-D scene (no library, no network): the rotor sphere with
// its magnets turned by the step's quaternion, the stator coils, the active pairs joined, the
// desired / step / cumulative axes, and optionally the simulated ball as ghost markers.
// Frames (MODEL.md): world +Z up, stator cap around -Z; q = [qx, qy, qz, qw] maps body to world.
// Test hook: window.spherestepView = {step(), setStep(k), orientation(), next(), prev(), ...};
// the URL hash #step=K opens step K; with the hash #selftest the page checks itself and writes JSON into #selftest-result.
(function () {
  "use strict";

  var data = JSON.parse(document.getElementById("spherestep-data").textContent);
  var steps = data.steps;
  var N = steps.length;
  var simByStep = {};
  (data.sim || []).forEach(function (s) { simByStep[s.step] = s; });

  // ---------- vector and quaternion helpers ----------
  function dot(a, b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
  function cross(a, b) {
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  }
  function scale(a, s) { return [a[0] * s, a[1] * s, a[2] * s]; }
  function add(a, b) { return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]; }
  function sub(a, b) { return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]; }
  function norm(a) { return Math.sqrt(dot(a, a)); }
  function normalize(a) { var n = norm(a); return n > 0 ? scale(a, 1 / n) : [0, 0, 1]; }
  // Rotate v by the unit quaternion q = [x, y, z, w].
  function qrot(q, v) {
    var u = [q[0], q[1], q[2]];
    var t = scale(cross(u, v), 2);
    return add(add(v, scale(t, q[3])), cross(u, t));
  }
  function qnormalize(q) {
    var n = Math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]) || 1;
    return [q[0] / n, q[1] / n, q[2] / n, q[3] / n];
  }
  function slerp(a, b, t) {
    var d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    if (d < 0) { b = [-b[0], -b[1], -b[2], -b[3]]; d = -d; }
    if (d > 0.9995) {
      return qnormalize([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]),
        a[2] + t * (b[2] - a[2]), a[3] + t * (b[3] - a[3])]);
    }
    var th = Math.acos(Math.min(1, d));
    var s = Math.sin(th);
    var wa = Math.sin((1 - t) * th) / s, wb = Math.sin(t * th) / s;
    return [wa * a[0] + wb * b[0], wa * a[1] + wb * b[1], wa * a[2] + wb * b[2],
      wa * a[3] + wb * b[3]];
  }
  // 3x3 matrices as arrays of rows.
  function mmul(A, B) {
    var C = [[0, 0, 0], [0, 0, 0], [0, 0, 0]];
    for (var i = 0; i < 3; i++) for (var j = 0; j < 3; j++)
      C[i][j] = A[i][0] * B[0][j] + A[i][1] * B[1][j] + A[i][2] * B[2][j];
    return C;
  }
  function mvec(A, v) { return [dot(A[0], v), dot(A[1], v), dot(A[2], v)]; }
  function rotX(a) { var c = Math.cos(a), s = Math.sin(a); return [[1, 0, 0], [0, c, -s], [0, s, c]]; }
  function rotY(a) { var c = Math.cos(a), s = Math.sin(a); return [[c, 0, s], [0, 1, 0], [-s, 0, c]]; }
  function rotZ(a) { var c = Math.cos(a), s = Math.sin(a); return [[c, -s, 0], [s, c, 0], [0, 0, 1]]; }
  // A tangent basis at unit vector n.
  function tangents(n) {
    var a = Math.abs(n[0]) < 0.9 ? [1, 0, 0] : [0, 1, 0];
    var t1 = normalize(cross(n, a));
    return [t1, cross(n, t1)];
  }
  // ---- pure text helpers (tests/view_text.rs runs them in node) ----
  // A number with d decimals; a value that rounds to zero is "0.000", never "-0.000".
  function fmt(x, d) {
    if (typeof x !== "number" || !isFinite(x)) return "\u2014";
    var t = x.toFixed(d);
    return /^-0(\.0*)?$/.test(t) ? t.slice(1) : t;
  }
  // A step's predicted settle time: a plan that predicts none (0 s) says so.
  function settleText(s) {
    return (typeof s === "number" && isFinite(s) && s > 0) ? fmt(s, 3) + " s" : "not predicted";
  }
  // ---- end of pure text helpers ----
  function fmtVec(v, d) {
    return v ? "[" + v.map(function (c) { return fmt(c, d); }).join(", ") + "]" : "\u2014";
  }

  // ---------- view state ----------
  var BG = [16, 20, 28];
  var COIL_R = 1.07; // coils drawn just outside the ball
  var AXIS_LEN = 1.5;
  var PAIR_COLORS = ["#ffb347", "#4fc3f7", "#f06292", "#aed581", "#ba68c8", "#fff176", "#4db6ac",
    "#ff8a65"];
  var COLORS = {
    desired: "#66bb6a", stepAxis: "#ffa726", cumAxis: "#e040fb", magnet: "#9fb3c8",
    coil: "#b87333", ghost: "#ff5252", sphere: "#3b5b85"
  };
  var DIST = 5; // camera distance in ball radii (perspective)
  var BASE_VIEW = [[1, 0, 0], [0, 0, 1], [0, -1, 0]]; // world X right, Z up, viewer at -Y
  function defaultView() { return mmul(rotX(-0.55), mmul(BASE_VIEW, rotZ(-0.5))); }

  var state = {
    step: 0,
    shown: steps.length ? steps[0].q.slice() : [0, 0, 0, 1],
    ghost: null,
    anim: null, // {from, to, gfrom, gto, t0, dur}
    playing: false,
    playTimer: null,
    view: defaultView(),
    zoom: 1,
    persp: true,
    labels: true,
    allLabels: false,
    showSim: true
  };

  var canvas = document.getElementById("view");
  var ctx = canvas.getContext("2d");
  var W = 800, H = 700, DPR = 1;

  function resize() {
    DPR = window.devicePixelRatio || 1;
    var cw = canvas.clientWidth || 800, ch = canvas.clientHeight || 700;
    W = cw; H = ch;
    canvas.width = Math.max(1, Math.round(cw * DPR));
    canvas.height = Math.max(1, Math.round(ch * DPR));
    draw();
  }

  // ---------- projection and occlusion ----------
  function baseScale() { return Math.min(W, H) * 0.3 * state.zoom; }
  function toCam(p) { return mvec(state.view, p); }
  function project(c) {
    var s = baseScale();
    var f = state.persp ? DIST / (DIST - c[2]) : 1;
    return [W / 2 + c[0] * s * f, H / 2 - c[1] * s * f, f];
  }
  // Is the camera-space point c hidden behind the unit ball?
  function occluded(c) {
    if (!state.persp) {
      var r2 = c[0] * c[0] + c[1] * c[1];
      return r2 < 1 && c[2] < Math.sqrt(1 - r2) - 1e-4;
    }
    var E = [0, 0, DIST];
    var d = sub(c, E);
    var a = dot(d, d), b = 2 * dot(E, d), cc = dot(E, E) - 1;
    var disc = b * b - 4 * a * cc;
    if (disc <= 0) return false;
    var t1 = (-b - Math.sqrt(disc)) / (2 * a);
    return t1 > 0 && t1 < 1 - 1e-4;
  }
  function silhouetteRadius() {
    var s = baseScale();
    return state.persp ? s * DIST / Math.sqrt(DIST * DIST - 1) : s;
  }

  // ---------- scene building: primitives with a depth and a hidden flag ----------
  var prims;
  function push(p) { prims.push(p); }

  // A polyline in world coordinates, split into segments each dimmed when hidden.
  function polyline(points, style) {
    var cams = points.map(toCam);
    for (var i = 0; i + 1 < cams.length; i++) {
      var mid = scale(add(cams[i], cams[i + 1]), 0.5);
      push({ kind: "seg", a: cams[i], b: cams[i + 1], z: mid[2], hidden: occluded(mid), style: style });
    }
  }
  function segmented(a, b, n, style) {
    var pts = [];
    for (var i = 0; i <= n; i++) pts.push(add(a, scale(sub(b, a), i / n)));
    polyline(pts, style);
  }
  // A small disc of radius r (ball radii) tangent to the sphere at world point p (a square
  // when sides = 4).
  function disc(p, r, style, sides) {
    var n = normalize(p), tb = tangents(n), pts = [], k = sides || 14;
    for (var i = 0; i < k; i++) {
      var a = 2 * Math.PI * (i + 0.5) / k;
      pts.push(toCam(add(p, add(scale(tb[0], r * Math.cos(a)), scale(tb[1], r * Math.sin(a))))));
    }
    var c = toCam(p);
    push({ kind: "disc", pts: pts, c: c, z: c[2], hidden: occluded(c), style: style });
  }
  function label(p, text, style) {
    var c = toCam(p);
    push({ kind: "label", c: c, z: c[2] + 0.3, hidden: occluded(c), text: text, style: style });
  }
  function greatCircle(q, axisBody, style) {
    var tb = tangents(axisBody), pts = [];
    for (var i = 0; i <= 72; i++) {
      var a = 2 * Math.PI * i / 72;
      pts.push(qrot(q, add(scale(tb[0], Math.cos(a)), scale(tb[1], Math.sin(a)))));
    }
    polyline(pts, style);
  }
  function arrowAxis(v, color, width, dash, name) {
    var u = normalize(v);
    if (state.labels && name) label(scale(u, AXIS_LEN + 0.14), name, { color: color, small: true });
    segmented(scale(u, -AXIS_LEN), scale(u, AXIS_LEN), 24, { color: color, width: width, dash: dash });
    // arrow head: two short segments in the plane containing the view direction
    var tip = scale(u, AXIS_LEN + 0.02);
    var side = cross(u, mvec(transpose(state.view), [0, 0, 1]));
    if (norm(side) < 1e-6) side = tangents(u)[0];
    side = normalize(side);
    var back = scale(u, AXIS_LEN - 0.1);
    polyline([add(back, scale(side, 0.05)), tip, add(back, scale(side, -0.05))],
      { color: color, width: width });
  }
  function transpose(A) {
    return [[A[0][0], A[1][0], A[2][0]], [A[0][1], A[1][1], A[2][1]], [A[0][2], A[1][2], A[2][2]]];
  }

  function buildScene() {
    prims = [];
    var st = steps[state.step] || null;
    var q = state.shown;
    var activeCoil = {}, activeMag = {}, pairs = st ? st.active : [];
    pairs.forEach(function (p, i) {
      activeCoil[p[0]] = i; activeMag[p[1]] = i;
    });
    var pivot = st && st.pivot ? st.pivot : null;

    // body-frame reference circles (show the ball turning)
    greatCircle(q, [0, 0, 1], { color: "rgba(150,180,220,0.55)", width: 1 });
    greatCircle(q, [1, 0, 0], { color: "rgba(150,180,220,0.3)", width: 1 });
    greatCircle(q, [0, 1, 0], { color: "rgba(150,180,220,0.3)", width: 1 });

    // stator coils (world frame)
    data.stator.forEach(function (s, i) {
      var p = scale(s, COIL_R);
      var k = activeCoil[i];
      var on = k !== undefined;
      disc(p, 0.085, {
        fill: on ? PAIR_COLORS[k % PAIR_COLORS.length] : COLORS.coil,
        stroke: on ? "#ffffff" : "#5a3413", width: on ? 2.5 : 1, alpha: 0.7
      }, 4);
      // On the coil's own square, just above it (a point further out along the coil's
      // direction drifts off the square in perspective, for the rim coils most).
      if (state.labels) label(p, "c" + i,
        { color: on ? PAIR_COLORS[k % PAIR_COLORS.length] : "#8b95a7", bold: on, dx: 0, dy: -16 });
    });

    // rotor magnets (body frame turned by q)
    data.rotor.forEach(function (r, j) {
      var p = qrot(q, r);
      var k = activeMag[j];
      var on = k !== undefined;
      disc(p, on ? 0.05 : 0.038, {
        fill: on ? PAIR_COLORS[k % PAIR_COLORS.length] : COLORS.magnet,
        stroke: on ? "#ffffff" : "#1e2633", width: 1
      });
      if (state.labels && (on || state.allLabels)) {
        label(p, "m" + j, { color: on ? "#ffffff" : "#8b95a7", small: !on, bold: on, dx: 0, dy: -14 });
      }
    });

    // active pairs joined
    pairs.forEach(function (pr, i) {
      var m = data.rotor[pr[1]], s = data.stator[pr[0]];
      if (!m || !s) return;
      var isPivot = pivot && pivot[0] === pr[0] && pivot[1] === pr[1];
      segmented(qrot(q, m), scale(s, COIL_R), 6,
        { color: PAIR_COLORS[i % PAIR_COLORS.length], width: isPivot ? 4 : 2.5 });
    });

    // simulated ball: ghost rings at the simulated magnet positions
    var g = currentGhost();
    if (g) {
      greatCircle(g, [0, 0, 1], { color: "rgba(255,82,82,0.6)", width: 1, dash: [4, 3] });
      data.rotor.forEach(function (r, j) {
        var on = activeMag[j] !== undefined;
        disc(qrot(g, r), on ? 0.06 : 0.045, { stroke: COLORS.ghost, width: on ? 2 : 1 });
      });
    }

    // axes
    if (data.desired_axis) arrowAxis(data.desired_axis.axis, COLORS.desired, 2.5, null, "desired");
    if (st && st.cum_axis) arrowAxis(st.cum_axis, COLORS.cumAxis, 2, [6, 4], "cum");
    if (st && st.step_axis) arrowAxis(st.step_axis, COLORS.stepAxis, 2, [2, 3], "step");
  }

  function currentGhost() {
    if (!state.showSim) return null;
    return state.ghost;
  }

  // ---------- drawing ----------
  function strokeStyle(style, hidden) {
    ctx.strokeStyle = style.color || style.stroke || "#fff";
    ctx.lineWidth = (style.width || 1) * (hidden ? 0.8 : 1);
    ctx.setLineDash(hidden ? [3, 4] : (style.dash || []));
    ctx.globalAlpha = hidden ? 0.28 : 1;
  }
  function drawPrim(p) {
    var hidden = p.hidden;
    if (p.kind === "seg") {
      var a = project(p.a), b = project(p.b);
      strokeStyle(p.style, hidden);
      ctx.beginPath(); ctx.moveTo(a[0], a[1]); ctx.lineTo(b[0], b[1]); ctx.stroke();
    } else if (p.kind === "disc") {
      ctx.setLineDash([]);
      ctx.globalAlpha = hidden ? 0.25 : 1;
      ctx.beginPath();
      p.pts.forEach(function (c, i) {
        var s = project(c);
        if (i === 0) ctx.moveTo(s[0], s[1]); else ctx.lineTo(s[0], s[1]);
      });
      ctx.closePath();
      if (p.style.fill) {
        ctx.fillStyle = p.style.fill;
        if (p.style.alpha && !hidden) ctx.globalAlpha = p.style.alpha;
        ctx.fill();
        ctx.globalAlpha = hidden ? 0.25 : 1;
      }
      if (p.style.stroke) {
        ctx.strokeStyle = p.style.stroke; ctx.lineWidth = p.style.width || 1; ctx.stroke();
      }
    } else if (p.kind === "label") {
      var s = project(p.c);
      ctx.setLineDash([]);
      ctx.globalAlpha = hidden ? 0.3 : 1;
      ctx.fillStyle = p.style.color;
      ctx.font = (p.style.bold ? "bold " : "") + (p.style.small ? "10px" : "12px") +
        " system-ui, sans-serif";
      ctx.textAlign = "center"; ctx.textBaseline = "middle";
      ctx.strokeStyle = "rgba(16,20,28,0.85)"; ctx.lineWidth = 3; ctx.lineJoin = "round";
      ctx.strokeText(p.text, s[0] + (p.style.dx || 0), s[1] + (p.style.dy || 0));
      ctx.fillText(p.text, s[0] + (p.style.dx || 0), s[1] + (p.style.dy || 0));
    }
  }
  function drawSphere() {
    var r = silhouetteRadius();
    var g = ctx.createRadialGradient(W / 2 - r * 0.35, H / 2 - r * 0.4, r * 0.1, W / 2, H / 2, r);
    g.addColorStop(0, "rgba(96,130,180,0.55)");
    g.addColorStop(1, "rgba(30,45,70,0.62)");
    ctx.globalAlpha = 1; ctx.setLineDash([]);
    ctx.fillStyle = g;
    ctx.beginPath(); ctx.arc(W / 2, H / 2, r, 0, 2 * Math.PI); ctx.fill();
    ctx.strokeStyle = "rgba(160,190,230,0.7)"; ctx.lineWidth = 1.2; ctx.stroke();
  }
  function drawTriad() {
    var o = [46, H - 56], L = 28;
    var names = ["X", "Y", "Z"], cols = ["#ef5350", "#66bb6a", "#42a5f5"];
    ctx.globalAlpha = 1; ctx.setLineDash([]);
    for (var i = 0; i < 3; i++) {
      var e = [0, 0, 0]; e[i] = 1;
      var c = toCam(e);
      ctx.strokeStyle = cols[i]; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.moveTo(o[0], o[1]); ctx.lineTo(o[0] + c[0] * L, o[1] - c[1] * L); ctx.stroke();
      ctx.fillStyle = cols[i]; ctx.font = "11px system-ui, sans-serif";
      ctx.textAlign = "center"; ctx.textBaseline = "middle";
      ctx.fillText(names[i], o[0] + c[0] * (L + 9), o[1] - c[1] * (L + 9));
    }
  }
  function draw() {
    ctx.setTransform(DPR, 0, 0, DPR, 0, 0);
    ctx.globalAlpha = 1;
    ctx.fillStyle = "rgb(" + BG.join(",") + ")";
    ctx.fillRect(0, 0, W, H);
    buildScene();
    prims.sort(function (a, b) { return a.z - b.z; });
    prims.forEach(function (p) { if (p.hidden) drawPrim(p); });
    drawSphere();
    prims.forEach(function (p) { if (!p.hidden) drawPrim(p); });
    ctx.globalAlpha = 1; ctx.setLineDash([]);
    drawTriad();
  }

  // ---------- stepping and animation ----------
  function now() { return (window.performance && performance.now) ? performance.now() : Date.now(); }
  function ghostFor(k) {
    var s = simByStep[steps[k] ? steps[k].step : -1];
    return s ? s.q : null;
  }
  function setStep(k, animate) {
    if (!N) return;
    k = Math.max(0, Math.min(N - 1, Math.round(Number(k) || 0)));
    var to = steps[k].q, gto = ghostFor(k);
    if (animate === false) {
      state.anim = null;
      state.shown = to.slice();
      state.ghost = gto;
    } else {
      state.anim = { from: state.shown.slice(), to: to, gfrom: state.ghost || gto, gto: gto,
        t0: now(), dur: 700 };
      var mine = state.anim;
      requestAnimationFrame(tick);
      // Where animation frames are throttled (hidden tab, headless), end the move on time.
      setTimeout(function () {
        if (state.anim === mine) { settle(); afterAnimation(); }
      }, mine.dur + 80);
    }
    state.step = k;
    updatePanel();
    draw();
  }
  function settle() {
    if (state.anim) {
      state.shown = state.anim.to.slice();
      state.ghost = state.anim.gto;
      state.anim = null;
    }
    draw();
  }
  function tick() {
    var a = state.anim;
    if (!a) return;
    var t = Math.min(1, (now() - a.t0) / a.dur);
    var e = t < 0.5 ? 2 * t * t : 1 - Math.pow(-2 * t + 2, 2) / 2; // ease in-out
    state.shown = slerp(a.from, a.to, e);
    state.ghost = a.gto ? (a.gfrom ? slerp(a.gfrom, a.gto, e) : a.gto) : null;
    if (t >= 1) { settle(); afterAnimation(); return; }
    draw();
    requestAnimationFrame(tick);
  }
  function afterAnimation() {
    if (!state.playing) return;
    clearTimeout(state.playTimer);
    state.playTimer = setTimeout(function () {
      if (!state.playing) return;
      if (state.step >= N - 1) { setPlaying(false); return; }
      setStep(state.step + 1);
    }, 450);
  }
  function setPlaying(on) {
    state.playing = !!on && N > 1;
    clearTimeout(state.playTimer);
    document.getElementById("play").innerHTML = state.playing ? "&#x2016; pause" : "&#x25B6; play";
    if (state.playing) {
      if (state.step >= N - 1) setStep(0); else setStep(state.step + 1);
    }
  }

  // ---------- side panel ----------
  function pairText(p) { return p[0] + ":" + p[1]; }
  function pairsHtml(list) {
    if (!list || !list.length) return "\u2014";
    return list.map(function (p, i) {
      var c = PAIR_COLORS[i % PAIR_COLORS.length];
      return '<span style="color:' + c + '">' + pairText(p) + "</span>";
    }).join("; ");
  }
  function esc(s) {
    return String(s).replace(/[&<>"]/g, function (c) {
      return { "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;" }[c];
    });
  }
  function updatePanel() {
    var st = steps[state.step];
    document.getElementById("step-number").textContent = String(st ? st.step : 0);
    document.getElementById("slider").value = String(state.step);
    document.getElementById("prev").disabled = state.step <= 0;
    document.getElementById("first").disabled = state.step <= 0;
    document.getElementById("next").disabled = state.step >= N - 1;
    document.getElementById("last").disabled = state.step >= N - 1;
    if (!st) return;
    var rows = [];
    function row(k, v) { rows.push("<tr><th>" + k + "</th><td>" + v + "</td></tr>"); }
    row("step", st.step + (state.step === 0 ? " (initial commutation state)" : ""));
    // active pairs are colored the same way as in the scene (by their order in `active`)
    row("active pairs", pairsHtml(st.active));
    row("pivot", st.pivot ? esc(pairText(st.pivot)) : "\u2014");
    row("new pairs", st.new.length ? esc(st.new.map(pairText).join("; ")) : "\u2014");
    row("step angle", fmt(st.step_angle_deg, 3) + "\u00B0");
    row("step axis error", fmt(st.step_axis_error_deg, 3) + "\u00B0");
    row("cumulative angle", fmt(st.cum_angle_deg, 3) + "\u00B0");
    row("cum. axis error", fmt(st.cum_axis_error_deg, 3) + "\u00B0");
    row("settle time", settleText(st.settle_time_s));
    row('<span style="color:' + COLORS.stepAxis + '">step axis</span>', fmtVec(st.step_axis, 3));
    row('<span style="color:' + COLORS.cumAxis + '">cumulative axis</span>', fmtVec(st.cum_axis, 3));
    if (data.desired_axis) {
      row('<span style="color:' + COLORS.desired + '">desired axis</span>',
        fmtVec(data.desired_axis.axis, 3) + " (" + esc(data.desired_axis.source) + ")");
    }
    row("orientation q", fmtVec(st.q, 4));
    if (data.sim) {
      var s = simByStep[st.step];
      if (s) {
        row('<span style="color:' + COLORS.ghost + '">simulated q</span>', fmtVec(s.q, 4));
        row('<span style="color:' + COLORS.ghost + '">sim deviation</span>',
          fmt(s.deviation_deg, 3) + "\u00B0" +
          (Math.abs(s.deviation_deg - s.computed_deviation_deg) > 1e-6
            ? " (from q: " + fmt(s.computed_deviation_deg, 3) + "\u00B0)" : ""));
      } else {
        row("simulated", "no row for this step");
      }
    }
    document.querySelector("#numbers tbody").innerHTML = rows.join("");
  }
  function buildLegend() {
    var items = [
      ['<i class="dot" style="background:' + COLORS.magnet + '"></i>', "rotor magnet"],
      ['<i class="sq" style="background:' + COLORS.coil + '"></i>', "stator coil (c#)"],
      ['<i style="border-color:' + PAIR_COLORS[0] + '"></i>', "active pair (thick: pivot)"],
      ['<i style="border-color:' + COLORS.desired + '"></i>', "desired axis"],
      ['<i class="dash" style="border-color:' + COLORS.stepAxis + '"></i>', "step axis"],
      ['<i class="dash" style="border-color:' + COLORS.cumAxis + '"></i>', "cumulative axis"]
    ];
    if (data.sim) items.push(['<i class="ring" style="border-color:' + COLORS.ghost + '"></i>',
      "simulated magnets (ghost)"]);
    items.push(["", "faint, dashed: behind the ball"]);
    document.getElementById("legend").innerHTML = items.map(function (it) {
      return "<div>" + it[0] + "<span>" + it[1] + "</span></div>";
    }).join("");
  }

  // ---------- input ----------
  var drag = null;
  canvas.addEventListener("pointerdown", function (e) {
    drag = { x: e.clientX, y: e.clientY, id: e.pointerId };
    canvas.classList.add("dragging");
    if (canvas.setPointerCapture) canvas.setPointerCapture(e.pointerId);
    e.preventDefault();
  });
  canvas.addEventListener("pointermove", function (e) {
    if (!drag || e.pointerId !== drag.id) return;
    var dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX; drag.y = e.clientY;
    var k = 1 / (baseScale() || 200);
    state.view = mmul(rotX(dy * k), mmul(rotY(dx * k), state.view));
    draw();
  });
  function endDrag() { drag = null; canvas.classList.remove("dragging"); }
  canvas.addEventListener("pointerup", endDrag);
  canvas.addEventListener("pointercancel", endDrag);
  canvas.addEventListener("wheel", function (e) {
    e.preventDefault();
    state.zoom = Math.max(0.4, Math.min(3, state.zoom * Math.exp(-e.deltaY * 0.001)));
    draw();
  }, { passive: false });
  document.getElementById("prev").onclick = function () { setPlaying(false); setStep(state.step - 1); };
  document.getElementById("next").onclick = function () { setPlaying(false); setStep(state.step + 1); };
  document.getElementById("first").onclick = function () { setPlaying(false); setStep(0); };
  document.getElementById("last").onclick = function () { setPlaying(false); setStep(N - 1); };
  document.getElementById("play").onclick = function () { setPlaying(!state.playing); };
  var slider = document.getElementById("slider");
  slider.max = String(Math.max(0, N - 1));
  slider.oninput = function () { setPlaying(false); setStep(Number(slider.value)); };
  document.addEventListener("keydown", function (e) {
    if (e.target && e.target.tagName === "INPUT" && e.target.type === "range") return;
    if (e.key === "ArrowRight") { setPlaying(false); setStep(state.step + 1); e.preventDefault(); }
    else if (e.key === "ArrowLeft") { setPlaying(false); setStep(state.step - 1); e.preventDefault(); }
    else if (e.key === " ") { setPlaying(!state.playing); e.preventDefault(); }
  });
  function bindCheck(id, key) {
    var el = document.getElementById(id);
    el.checked = state[key];
    el.onchange = function () { state[key] = el.checked; draw(); };
  }
  bindCheck("opt-persp", "persp");
  bindCheck("opt-labels", "labels");
  bindCheck("opt-all", "allLabels");
  bindCheck("opt-sim", "showSim");
  if (!data.sim) document.getElementById("opt-sim-label").style.display = "none";
  document.getElementById("reset-view").onclick = function () {
    state.view = defaultView(); state.zoom = 1; draw();
  };
  window.addEventListener("resize", resize);

  // ---------- start ----------
  document.title = data.title || "spherestep plan";
  document.getElementById("title").textContent = data.title || "spherestep plan";
  document.getElementById("subtitle").textContent = "scenario " + data.scenario + " \u00B7 " +
    data.rotor.length + " magnets \u00B7 " + data.stator.length + " coils \u00B7 " + N + " steps" +
    (data.sim ? " \u00B7 " + data.sim.length + " simulated" : "");
  document.getElementById("step-count").textContent = String(N ? steps[N - 1].step : 0);
  buildLegend();
  resize();
  setStep(0, false);

  var api = {
    /** Index of the current step (0 = the initial commutation state). */
    step: function () { return state.step; },
    /** Go to step k (clamped); animates unless animate === false. */
    setStep: function (k, animate) { setStep(k, animate); return state.step; },
    /** The current step's planned orientation [qx, qy, qz, qw]. */
    orientation: function () { return steps[state.step] ? steps[state.step].q.slice() : null; },
    /** The orientation drawn now (mid-animation it lies between two steps). */
    displayedOrientation: function () { return state.shown.slice(); },
    next: function () { setStep(state.step + 1); return state.step; },
    prev: function () { setStep(state.step - 1); return state.step; },
    /** Ends a running animation at once. */
    settle: settle,
    play: function () { setPlaying(true); },
    pause: function () { setPlaying(false); },
    stepCount: function () { return N; },
    data: data
  };
  window.spherestepView = api;

  // ---------- #selftest: checks run in the page, result as JSON in #selftest-result ----------
  function nonBlankPixels() {
    var img = ctx.getImageData(0, 0, canvas.width, canvas.height).data, n = 0;
    for (var i = 0; i < img.length; i += 4) {
      if (Math.abs(img[i] - BG[0]) + Math.abs(img[i + 1] - BG[1]) + Math.abs(img[i + 2] - BG[2]) > 24) n++;
    }
    return n;
  }
  function selftest() {
    var r = { errors: window.__spherestepErrors || [] };
    try {
      r.stepCount = N;
      r.canvas = [canvas.width, canvas.height];
      r.nonBlankPixels = nonBlankPixels();
      r.totalPixels = canvas.width * canvas.height;
      r.stepBefore = api.step();
      r.labelBefore = document.getElementById("step-number").textContent;
      r.orientationBefore = api.orientation();
      r.stepAfterNext = api.next();
      api.settle();
      r.labelAfterNext = document.getElementById("step-number").textContent;
      r.orientationAfterNext = api.orientation();
      r.displayedAfterNext = api.displayedOrientation();
      r.nonBlankAfterNext = nonBlankPixels();
      r.stepAfterSetLast = api.setStep(N - 1, false);
      r.labelAfterSetLast = document.getElementById("step-number").textContent;
      r.stepAfterPrev = api.prev();
      api.settle();
      r.labelAfterPrev = document.getElementById("step-number").textContent;
      r.orientationAfterPrev = api.orientation();
      api.setStep(0, false);
    } catch (e) {
      r.errors.push("selftest: " + (e && e.message ? e.message : String(e)));
    }
    r.errors = r.errors.slice();
    var out = document.getElementById("selftest-result");
    out.textContent = JSON.stringify(r);
    out.hidden = false;
  }
  var m = /^#step=(\d+)$/.exec(location.hash);
  if (m) setStep(Number(m[1]), false);
  if (location.hash === "#selftest") selftest();
})();
