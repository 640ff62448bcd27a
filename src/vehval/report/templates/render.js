/* vehval report: render the embedded figure JSON with plotly.js (lazily, when near the
   viewport) and keep the time axes of linked plots in step. No network access. */
(function () {
  "use strict";
  var ready = window.vehvalPlotly || Promise.resolve();  /* boot.js: plotly.js unpacked */
  var template = JSON.parse(document.getElementById("vv-template").textContent);
  var config = {responsive: true, displaylogo: false, scrollZoom: false,
                modeBarButtonsToRemove: ["sendDataToCloud", "lasso2d", "select2d"]};
  var figs = Array.prototype.slice.call(document.querySelectorAll(".vv-fig"));
  var pending = {};
  var xrange = null, syncing = false;
  var sync = document.getElementById("vv-sync");  /* the test report's "link time axes" */
  function linked() { return !!sync && sync.checked; }
  function xkeys(el) {
    return Object.keys(el.layout || {}).filter(function (k) { return /^xaxis\d*$/.test(k); });
  }
  function applyRange(el, range) {
    var upd = {};
    xkeys(el).forEach(function (k) {
      if (range) { upd[k + ".range"] = range.slice(); } else { upd[k + ".autorange"] = true; }
    });
    return Plotly.relayout(el, upd);
  }
  function onRelayout(el, ev) {
    if (syncing || !linked()) return;
    var range = null, auto = false;
    Object.keys(ev).forEach(function (k) {
      var m = /^(xaxis\d*)\.range\[(0|1)\]$/.exec(k);
      if (m) { range = range || [null, null]; range[+m[2]] = ev[k]; }
      if (/^xaxis\d*\.range$/.test(k)) range = ev[k].slice();
      if (/^xaxis\d*\.autorange$/.test(k) && ev[k]) auto = true;
    });
    if (!range && !auto) return;
    if (range && (range[0] === null || range[1] === null)) return;
    xrange = auto ? null : range;
    syncing = true;
    var jobs = figs.filter(function (o) { return o !== el && o.dataset.linked && o.dataset.rendered; })
                   .map(function (o) { return applyRange(o, xrange); });
    Promise.all(jobs).then(function () { syncing = false; }, function () { syncing = false; });
  }
  function render(el) {
    if (pending[el.id]) return pending[el.id];
    pending[el.id] = ready.then(function () { return draw(el); }, function (err) {
      el.textContent = "Figure not drawn: " + err.message;
      return el;
    });
    return pending[el.id];
  }
  function draw(el) {
    var spec = JSON.parse(document.getElementById(el.dataset.src).textContent);
    var layout = spec.layout || {};
    layout.template = template;
    if (el.dataset.linked && xrange && linked()) {
      xkeys({layout: layout}).forEach(function (k) { layout[k].range = xrange.slice(); layout[k].autorange = false; });
    }
    return Plotly.newPlot(el, spec.data || [], layout, config).then(function () {
      el.dataset.rendered = "1";
      el.style.minHeight = "";
      if (el.dataset.linked) el.on("plotly_relayout", function (ev) { onRelayout(el, ev); });
      return el;
    });
  }
  function renderAll() { return Promise.all(figs.map(render)); }
  window.vehvalReport = {renderAll: renderAll, figures: figs};
  if ("IntersectionObserver" in window) {
    var io = new IntersectionObserver(function (entries) {
      entries.forEach(function (e) { if (e.isIntersecting) { io.unobserve(e.target); render(e.target); } });
    }, {rootMargin: "800px 0px"});
    figs.forEach(function (el) { io.observe(el); });
  } else {
    renderAll();
  }
  window.addEventListener("beforeprint", renderAll);
})();
