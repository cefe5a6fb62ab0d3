// The jobs page: the job store's jobs, refreshed every 2 s.
(function () {
  "use strict";
  function esc(s) { var d = document.createElement("span"); d.textContent = String(s === null || s === undefined ? "" : s); return d.innerHTML; }
  function figures(m) {
    var keys = ["moves", "chamfer_mean_px", "chamfer_max_px", "t_end_ratio", "quality", "estimated_s"];
    return keys.filter(function (k) { return m[k] !== undefined; }).map(function (k) {
      var v = m[k]; return k + " " + (typeof v === "number" ? Number(v.toPrecision(3)) : v);
    }).join(", ");
  }
  function refresh() {
    fetch("/api/jobs").then(function (r) { return r.json(); }).then(function (d) {
      var rows = (d.jobs || []).map(function (j) {
        var progress = j.total ? Math.round(100 * j.step / j.total) + " %" : "";
        var status = esc(j.status) + (j.error ? "<br><span class='bad'>" + esc(j.error) + "</span>" : "");
        return "<tr class='job " + esc(j.status) + "' data-id='" + esc(j.id) + "'><td><a href='/job/" + esc(j.id) + "'>" +
          esc(j.id.slice(0, 8)) + "</a></td><td>" + esc(j.kind) + "</td><td>" + esc(j.label) + "</td><td>" + status +
          "</td><td>" + progress + "</td><td>" + esc(figures(j.metrics || {})) + "</td><td>" + esc(j.created) + "</td></tr>";
      });
      document.querySelector("#jobs tbody").innerHTML = rows.join("") ||
        "<tr><td colspan='7'>No jobs yet: fit a drawing in the studio.</td></tr>";
    });
  }
  refresh();
  setInterval(refresh, 2000);
})();
