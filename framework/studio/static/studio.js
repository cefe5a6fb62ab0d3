// inkmotion studio: draw / drop / pick a drawing, fit it live, animate the motion at its
// ΣΛ speed, send it to a plotter, the arm or the queue. No framework: the page is small.
(function () {
  "use strict";
  var config = JSON.parse(document.getElementById("studio-config").textContent);
  var $ = function (id) { return document.getElementById(id); };
  var state = {
    tab: "draw", strokes: [], upload: null, job: null, source: null, result: null,
    playing: false, t: 0, frames: 0, frameTimes: [], firstEventMs: null, fitPressedAt: null,
    sent: {}
  };
  window.studio = state; // for the browser tests and the curious

  // -- messages -----------------------------------------------------------------------
  function say(text, bad) {
    var m = $("message");
    m.textContent = text || "";
    m.className = bad ? "bad" : "";
  }
  function status(text) { $("status").textContent = text; }
  function api(method, url, body, headers) {
    var opts = {method: method, headers: headers || {}};
    if (body !== undefined) {
      if (body instanceof Blob || body instanceof ArrayBuffer) {
        opts.body = body;
        opts.headers["Content-Type"] = "application/octet-stream";
      } else {
        opts.body = JSON.stringify(body);
        opts.headers["Content-Type"] = "application/json";
      }
    }
    return fetch(url, opts).then(function (r) {
      return r.json().catch(function () { return {error: "The studio answered " + r.status + "."}; })
        .then(function (data) {
          if (!r.ok) { throw new Error(data.error || ("The studio answered " + r.status + ".")); }
          return data;
        });
    });
  }

  // -- tabs ---------------------------------------------------------------------------
  document.querySelectorAll(".tab").forEach(function (b) {
    b.addEventListener("click", function () {
      state.tab = b.dataset.tab;
      document.querySelectorAll(".tab").forEach(function (o) { o.classList.toggle("active", o === b); });
      document.querySelectorAll(".pane").forEach(function (p) {
        p.classList.toggle("hidden", p.dataset.pane !== state.tab);
      });
    });
  });

  // -- the drawing pad: pointer events with their times and pressure ------------------
  var pad = $("pad"), pctx = pad.getContext("2d"), drawing = null;
  function padPoint(e) {
    var r = pad.getBoundingClientRect();
    var x = (e.clientX - r.left) * pad.width / r.width, y = (e.clientY - r.top) * pad.height / r.height;
    var p = e.pressure || (e.pointerType === "mouse" ? 0.5 : 0);
    return [Math.round(x * 100) / 100, Math.round(y * 100) / 100, e.timeStamp, p];
  }
  function redrawPad() {
    pctx.fillStyle = "#fff"; pctx.fillRect(0, 0, pad.width, pad.height);
    pctx.strokeStyle = "#111"; pctx.lineCap = "round"; pctx.lineJoin = "round";
    state.strokes.forEach(function (s) {
      pctx.beginPath();
      s.forEach(function (p, i) {
        pctx.lineWidth = 1.5 + 3 * (p[3] || 0.5);
        if (i === 0) { pctx.moveTo(p[0], p[1]); } else { pctx.lineTo(p[0], p[1]); }
      });
      pctx.stroke();
    });
    var n = state.strokes.length;
    $("pad-info").textContent = n ? n + " stroke" + (n > 1 ? "s" : "") + " recorded with their timing." :
      "Draw here: each stroke is recorded with its timing.";
  }
  pad.addEventListener("pointerdown", function (e) {
    pad.setPointerCapture(e.pointerId);
    drawing = [padPoint(e)];
    state.strokes.push(drawing);
    e.preventDefault();
  });
  pad.addEventListener("pointermove", function (e) {
    if (!drawing) { return; }
    var events = e.getCoalescedEvents ? e.getCoalescedEvents() : [e];
    if (!events.length) { events = [e]; }
    events.forEach(function (c) { drawing.push(padPoint(c)); });
    redrawPad();
  });
  function endStroke() {
    if (drawing && drawing.length < 2) { state.strokes.pop(); }
    drawing = null; redrawPad();
  }
  pad.addEventListener("pointerup", endStroke);
  pad.addEventListener("pointercancel", endStroke);
  $("pad-clear").addEventListener("click", function () { state.strokes = []; redrawPad(); });
  $("pad-undo").addEventListener("click", function () { state.strokes.pop(); redrawPad(); });
  redrawPad();

  // -- a file: dropped or picked, checked by the studio at once -----------------------
  function sendFile(file) {
    say("");
    $("upload-status").textContent = "Checking " + file.name + " …";
    state.upload = null;
    api("POST", "/api/uploads", file, {"X-Filename": encodeURIComponent(file.name)}).then(function (d) {
      state.upload = d.upload;
      $("upload-status").textContent = d.name + " (" + Math.round(d.bytes / 1024) + " KB) is ready to fit.";
    }).catch(function (err) {
      $("upload-status").textContent = "";
      say(err.message, true);
    });
  }
  $("file").addEventListener("change", function () { if (this.files[0]) { sendFile(this.files[0]); } });
  var drop = $("drop");
  ["dragenter", "dragover"].forEach(function (n) {
    drop.addEventListener(n, function (e) { e.preventDefault(); drop.classList.add("over"); });
  });
  ["dragleave", "drop"].forEach(function (n) {
    drop.addEventListener(n, function (e) { e.preventDefault(); drop.classList.remove("over"); });
  });
  drop.addEventListener("drop", function (e) {
    if (e.dataTransfer.files[0]) { sendFile(e.dataTransfer.files[0]); }
  });

  // -- a fit --------------------------------------------------------------------------
  function input() {
    if (state.tab === "draw") {
      if (!state.strokes.length) { throw new Error("Draw something on the pad first."); }
      return {drawing: {width: pad.width, height: pad.height, strokes: state.strokes}};
    }
    if (state.tab === "word") { return {text: $("word").value}; }
    if (state.tab === "sample") { return {sample: $("sample").value}; }
    if (!state.upload) { throw new Error("Drop or pick a file first, and wait until it is checked."); }
    return {upload: state.upload};
  }
  function settings() {
    return {
      lambda_smooth: Number($("lambda_smooth").value), tolerance: Number($("tolerance").value),
      targets: $("targets").value, size: Number($("size").value), steps: Number($("steps").value),
      renderer: $("renderer").value, varying_width: $("varying_width").checked,
      invert: $("invert").checked
    };
  }
  $("fit").addEventListener("click", function () {
    var body;
    try { body = {input: input(), settings: settings()}; } catch (err) { say(err.message, true); return; }
    say("");
    stopPlaying();
    state.result = null; state.sent = {}; $("sent").innerHTML = "";
    state.fitPressedAt = performance.now(); state.firstEventMs = null;
    $("fit").disabled = true;
    status("Starting the fit …");
    api("POST", "/api/fits", body).then(function (d) {
      follow(d.job);
    }).catch(function (err) { $("fit").disabled = false; status("Nothing fitted."); say(err.message, true); });
  });
  $("cancel").addEventListener("click", function () {
    if (!state.job) { return; }
    api("POST", "/api/jobs/" + state.job + "/cancel", {}).catch(function (err) { say(err.message, true); });
  });

  var source = null;
  function follow(job) {
    state.job = job;
    history.replaceState(null, "", "/job/" + job);
    $("cancel").disabled = false;
    if (source) { source.close(); }
    source = new EventSource("/api/jobs/" + job + "/events");
    state.source = source;
    source.onmessage = function (m) {
      var e = JSON.parse(m.data);
      if (state.firstEventMs === null && state.fitPressedAt !== null &&
          (e.type === "start" || e.type === "step")) {
        state.firstEventMs = performance.now() - state.fitPressedAt;
      }
      onEvent(job, e);
    };
    source.onerror = function () { /* the browser reconnects; the end event closes it */ };
  }
  var live = {canvas: null, traces: [], paths: []};
  function onEvent(job, e) {
    if (e.type === "queued") { status("Queued: waiting for a free core …"); }
    else if (e.type === "running") { status("Reading the drawing and planning the first targets …"); }
    else if (e.type === "start") {
      live = {canvas: e.canvas, traces: e.traces, paths: [], total: e.total};
      status("Fitting: step 0 of " + e.total + ".");
      drawLive();
    } else if (e.type === "step" || e.type === "record") {
      var pct = e.total ? 100 * e.step / e.total : 0;
      $("progress-bar").style.width = pct.toFixed(1) + "%";
      var f = e.figures || {}, words = [];
      if (f.loss !== undefined && f.loss !== null) { words.push("loss " + f.loss.toPrecision(4)); }
      if (f.T_end !== undefined && f.T_end !== null) { words.push("T_end " + f.T_end.toFixed(3) + " s"); }
      Object.keys(e.words || {}).forEach(function (k) { words.push(k + " " + e.words[k]); });
      status("Fitting: step " + e.step + " of " + e.total + (words.length ? " · " + words.join(", ") : "") + ".");
      if (e.paths) { live.paths = e.paths; drawLive(); }
    } else if (e.type === "end") {
      source.close();
      $("cancel").disabled = true; $("fit").disabled = false;
      if (e.status === "succeeded") {
        $("progress-bar").style.width = "100%";
        status("Done. Loading the motion …");
        loadResult(job);
      } else if (e.status === "cancelled") {
        $("progress-bar").style.width = "0";
        status("Cancelled: nothing was kept.");
      } else {
        clearResult();  // the last fit's motion, figures and links are not this one's
        status("The fit failed.");
        say(e.error || "The job " + e.status + ".", true);
      }
    }
  }

  // -- drawing the motion ---------------------------------------------------------------
  var view = $("view"), vctx = view.getContext("2d");
  function fitTransform(canvas) {
    var s = Math.min(view.width / canvas[0], view.height / canvas[1]);
    return {s: s, ox: (view.width - s * canvas[0]) / 2, oy: (view.height - s * canvas[1]) / 2};
  }
  function poly(ctx, tf, pts, upto) {
    ctx.beginPath();
    var n = upto === undefined ? pts.length : upto;
    for (var i = 0; i < n; i++) {
      var x = tf.ox + tf.s * pts[i][0], y = tf.oy + tf.s * pts[i][1];
      if (i === 0) { ctx.moveTo(x, y); } else { ctx.lineTo(x, y); }
    }
    ctx.stroke();
  }
  function background(canvas, traces) {
    vctx.fillStyle = "#fbfaf7"; vctx.fillRect(0, 0, view.width, view.height);
    var tf = fitTransform(canvas);
    vctx.strokeStyle = "#e2ddd3"; vctx.strokeRect(tf.ox, tf.oy, tf.s * canvas[0], tf.s * canvas[1]);
    vctx.strokeStyle = "#c9c3b8"; vctx.lineWidth = 6; vctx.lineCap = "round"; vctx.lineJoin = "round";
    (traces || []).forEach(function (t) { poly(vctx, tf, t); });
    return tf;
  }
  function drawLive() {
    if (!live.canvas) { return; }
    var tf = background(live.canvas, live.traces);
    vctx.strokeStyle = "#2a5bd7"; vctx.lineWidth = 2;
    live.paths.forEach(function (p) { poly(vctx, tf, p); });
  }
  function speedColour(v, vmax) {
    var h = 240 - 240 * Math.min(1, v / (vmax || 1));
    return "hsl(" + h.toFixed(0) + ",80%,45%)";
  }
  function drawMotion(t) {
    var r = state.result;
    var tf = background(r.canvas, r.traces);
    vctx.lineWidth = 2.5;
    var pen = null;
    r.paths.forEach(function (p, k) {
      var local = t - p.start;
      if (local < 0) { return; }
      var n = p.t.length, i;
      for (i = 1; i < n && p.t[i] <= local; i++) {
        vctx.strokeStyle = speedColour(p.speed[i], r.peak_speed);
        // a 2.5D plan (varying width): the stroke is as wide as its radius says
        vctx.lineWidth = p.radius ? Math.max(1, 2 * p.radius[i] * tf.s) : 2.5;
        vctx.beginPath();
        vctx.moveTo(tf.ox + tf.s * p.xy[i - 1][0], tf.oy + tf.s * p.xy[i - 1][1]);
        vctx.lineTo(tf.ox + tf.s * p.xy[i][0], tf.oy + tf.s * p.xy[i][1]);
        vctx.stroke();
      }
      if (i < n) { pen = {xy: p.xy[i - 1], down: true}; }
      else if (k + 1 < r.paths.length && t < r.paths[k + 1].start) {
        var q = r.paths[k + 1], a = p.xy[n - 1], b = q.xy[0];
        var f = (t - (p.start + p.t[n - 1])) / r.pen_lift_s;
        vctx.save(); vctx.setLineDash([4, 4]); vctx.strokeStyle = "#888"; vctx.lineWidth = 1;
        vctx.beginPath(); vctx.moveTo(tf.ox + tf.s * a[0], tf.oy + tf.s * a[1]);
        vctx.lineTo(tf.ox + tf.s * b[0], tf.oy + tf.s * b[1]); vctx.stroke(); vctx.restore();
        pen = {xy: [a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])], down: false};
      }
      if ($("show-targets").checked) {
        vctx.fillStyle = "#333";
        p.targets.forEach(function (c) { vctx.fillRect(tf.ox + tf.s * c[0] - 2, tf.oy + tf.s * c[1] - 2, 4, 4); });
      }
    });
    if (pen) {
      vctx.beginPath();
      vctx.arc(tf.ox + tf.s * pen.xy[0], tf.oy + tf.s * pen.xy[1], pen.down ? 5 : 4, 0, 2 * Math.PI);
      vctx.fillStyle = pen.down ? "#111" : "#fff"; vctx.fill();
      vctx.strokeStyle = "#111"; vctx.lineWidth = 1.5; vctx.stroke();
    }
    drawSpeed(t);
    $("clock").textContent = t.toFixed(2) + " s of " + r.duration.toFixed(2) + " s";
  }
  var speed = $("speed"), sctx = speed.getContext("2d");
  function drawSpeed(t) {
    var r = state.result, W = speed.width, H = speed.height, pad = 24;
    sctx.fillStyle = "#fff"; sctx.fillRect(0, 0, W, H);
    var T = r.duration || 1, vmax = r.peak_speed || 1;
    var X = function (s) { return pad + (W - 2 * pad) * s / T; };
    var Y = function (v) { return H - pad - (H - 2 * pad) * v / vmax; };
    r.paths.forEach(function (p) {
      sctx.strokeStyle = "rgba(120,120,120,0.6)"; sctx.lineWidth = 1;
      p.bells.forEach(function (b) {
        sctx.beginPath();
        b.forEach(function (v, i) { var x = X(p.start + p.t[i]), y = Y(v); if (i) { sctx.lineTo(x, y); } else { sctx.moveTo(x, y); } });
        sctx.stroke();
      });
      sctx.strokeStyle = "#2a5bd7"; sctx.lineWidth = 2; sctx.beginPath();
      p.speed.forEach(function (v, i) { var x = X(p.start + p.t[i]), y = Y(v); if (i) { sctx.lineTo(x, y); } else { sctx.moveTo(x, y); } });
      sctx.stroke();
    });
    sctx.strokeStyle = "#d33"; sctx.beginPath(); sctx.moveTo(X(t), pad / 2); sctx.lineTo(X(t), H - pad); sctx.stroke();
    sctx.fillStyle = "#555"; sctx.font = "11px sans-serif";
    sctx.fillText("speed, px/s (peak " + Math.round(vmax) + ")", pad, 12);
    sctx.fillText(T.toFixed(2) + " s", W - pad - 30, H - 6);
  }

  // -- the animation at the ΣΛ speed ---------------------------------------------------
  var last = null;
  function frame(now) {
    if (!state.playing) { return; }
    state.frames += 1; state.frameTimes.push(now);
    if (state.frameTimes.length > 240) { state.frameTimes.shift(); }
    if (last !== null) { state.t += (now - last) / 1000 * Number($("rate").value); }
    last = now;
    var end = state.result.duration;
    if (state.t >= end) { state.t = end; drawMotion(end); stopPlaying(); return; }
    drawMotion(state.t);
    requestAnimationFrame(frame);
  }
  function play() {
    if (!state.result) { return; }
    if (state.t >= state.result.duration) { state.t = 0; }
    state.playing = true; last = null; state.frameTimes = [];
    $("play").textContent = "❚❚ Pause";
    requestAnimationFrame(frame);
  }
  function stopPlaying() { state.playing = false; $("play").textContent = "▶ Play"; }
  state.fps = function () {
    var f = state.frameTimes;
    return f.length > 1 ? 1000 * (f.length - 1) / (f[f.length - 1] - f[0]) : 0;
  };
  $("play").addEventListener("click", function () { if (state.playing) { stopPlaying(); } else { play(); } });
  $("show-targets").addEventListener("change", function () { if (state.result) { drawMotion(state.t); } });

  // -- the result: figures in words, downloads, sending it on ---------------------------
  function esc(s) { var d = document.createElement("span"); d.textContent = String(s); return d.innerHTML; }
  function words(r) {
    var f = r.figures, out = [];
    if (f.moves !== undefined) {
      var paths = r.paths.length;
      out.push(f.moves + " sub-movements (virtual targets) over " + paths + " pen-down path" + (paths > 1 ? "s" : "") +
               ", drawn in " + r.duration.toFixed(2) + " s" + (paths > 1 ? " with pen lifts" : "") + ".");
    }
    if (f.chamfer_mean_px !== undefined) {
      out.push("The motion stays within " + f.chamfer_mean_px.toFixed(2) + " px of the drawing on average, " +
               f.chamfer_max_px.toFixed(1) + " px at most (Chamfer distance).");
    }
    if (f.t_end_ratio !== undefined) {
      out.push("It takes " + Math.round(100 * f.t_end_ratio) + " % of the time of the plan it started from (T_end ratio " +
               f.t_end_ratio.toFixed(2) + ").");
    }
    if (f.quality) { out.push("Quality: " + f.quality + "."); }
    if (r.extraction) {
      out.push("From the picture: " + r.extraction.strokes + " strokes, " + r.extraction.pen_lifts + " pen lifts.");
    }
    return out;
  }
  function clearResult() {
    state.job = null; state.result = null; state.t = 0;
    $("figures").innerHTML = ""; $("downloads").innerHTML = "";
    $("recorded").classList.add("hidden");
    $("send").classList.add("disabled-block");
    $("progress-bar").style.width = "0";
    stopPlaying(); $("play").disabled = true; $("clock").textContent = "";
    vctx.fillStyle = "#fbfaf7"; vctx.fillRect(0, 0, view.width, view.height);
    sctx.fillStyle = "#fff"; sctx.fillRect(0, 0, speed.width, speed.height);
  }
  function loadResult(job) {
    return api("GET", "/api/jobs/" + job + "/result").then(function (r) {
      state.job = job;
      if (!r.paths) { status("This job has no motion to show (" + esc(r.kind) + ")."); return; }
      state.result = r; state.t = 0;
      status("Done: " + r.label + ".");
      $("figures").innerHTML = words(r).map(function (w) { return "<p>" + esc(w) + "</p>"; }).join("") +
        r.warnings.map(function (w) { return "<p class='bad'>" + esc(w) + "</p>"; }).join("");
      if (r.files.indexOf("human_speeds.png") >= 0) {
        $("recorded-img").src = "/api/jobs/" + job + "/files/human_speeds.png?inline=1";
        $("recorded").classList.remove("hidden");
      } else { $("recorded").classList.add("hidden"); }
      var wanted = ["plan.json", "drawing.svg", "trajectory.csv", "overlay.png", "recording.rrd", "job.json"];
      $("downloads").innerHTML = "Download: " + wanted.filter(function (n) { return r.files.indexOf(n) >= 0; })
        .map(function (n) { return "<a class='download' href='/api/jobs/" + job + "/files/" + n + "'>" + esc(n) + "</a>"; }).join(" ");
      if (r.files.indexOf("recording.rrd") >= 0) {
        $("downloads").insertAdjacentHTML("beforeend", " <button type='button' id='open-rerun'>Open in rerun's viewer</button>");
        $("open-rerun").addEventListener("click", function () {
          var tab = window.open("about:blank", "_blank");
          api("POST", "/api/jobs/" + job + "/rerun", {}).then(function (d) {
            state.rerunUrl = d.url;
            if (tab) { tab.location = d.url; }
          }).catch(function (err) { if (tab) { tab.close(); } say(err.message, true); });
        });
      }
      $("send").classList.remove("disabled-block");
      $("play").disabled = false;
      drawMotion(0);
      play();
    }).catch(function (err) { say(err.message, true); });
  }
  function sendTo(kind) {
    if (!state.result) { say("Fit a drawing first.", true); return; }
    var body = {kind: kind};
    if (kind === "plot") { body.paper = $("paper").value; body.machine = $("machine").value; }
    if (kind === "draw") { body.robot = $("robot").value; body.dry_run = $("dry-run").checked; }
    var box = document.createElement("div");
    box.className = "sent"; box.id = "sent-" + kind;
    var old = $("sent-" + kind); if (old) { old.remove(); }
    $("sent").appendChild(box);
    box.textContent = kind + ": starting …";
    api("POST", "/api/jobs/" + state.job + "/send", body).then(function (d) {
      state.sent[kind] = d.job;
      var es = new EventSource("/api/jobs/" + d.job + "/events");
      es.onmessage = function (m) {
        var e = JSON.parse(m.data);
        if (e.type === "step" || e.type === "record") {
          box.textContent = kind + ": step " + e.step + " of " + e.total + " …";
        } else if (e.type === "end") {
          es.close();
          if (e.status !== "succeeded") {
            box.innerHTML = "<span class='bad'>" + esc(kind + " " + e.status + ": " + (e.error || "")) + "</span>";
            return;
          }
          api("GET", "/api/jobs/" + d.job + "/result").then(function (r) { showSent(box, kind, d.job, r); });
        }
      };
    }).catch(function (err) { box.innerHTML = "<span class='bad'>" + esc(err.message) + "</span>"; });
  }
  function showSent(box, kind, job, r) {
    var link = function (n, label) {
      return r.files.indexOf(n) >= 0 ? "<a class='download' href='/api/jobs/" + job + "/files/" + n + "'>" + esc(label || n) + "</a> " : "";
    };
    var f = r.figures, html = "<h3>" + esc(kind) + " — done</h3>";
    if (kind === "plot") {
      html += "<p>Estimated plotting time " + (f.estimated_s || 0).toFixed(0) + " s; " + Math.round(f.drawn_mm || 0) +
        " mm drawn, " + Math.round(f.travel_mm || 0) + " mm of pen-up travel.</p>";
      if (r.files.indexOf("plot_preview.png") >= 0) {
        html += "<img class='paper' alt='The drawing on the paper' src='/api/jobs/" + job + "/files/plot_preview.png?inline=1'>";
      }
      html += "<p>" + link("plot.gcode", "G-code (plot.gcode)") + link("plot.svg") + link("feed.png") + "</p>";
    } else {
      if (r.files.indexOf("side_by_side.png") >= 0) {
        html += "<img class='paper' alt='The plan and what the arm drew' src='/api/jobs/" + job + "/files/side_by_side.png?inline=1'>";
      }
      html += "<p>" + Object.keys(f).map(function (k) { return esc(k + " " + f[k]); }).join(", ") + "</p><p>" +
        r.files.filter(function (n) { return /\.(png|json|csv|gcode|rrd|mp4)$/.test(n); }).map(function (n) { return link(n); }).join("") + "</p>";
    }
    html += "<p><a href='/jobs'>All jobs</a></p>";
    box.innerHTML = html;
  }
  $("send-plot").addEventListener("click", function () { sendTo("plot"); });
  $("send-simulate").addEventListener("click", function () { sendTo("simulate"); });
  $("send-draw").addEventListener("click", function () { sendTo("draw"); });

  // -- a job given in the address: show it (and follow it while it runs) ----------------
  if (config.job) {
    api("GET", "/api/jobs/" + config.job + "/result").then(function () { loadResult(config.job); })
      .catch(function () { follow(config.job); });
  }
})();
