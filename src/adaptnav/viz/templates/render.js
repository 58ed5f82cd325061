// Draws each interactive figure of the report (adaptnav.viz.report, docs/report.md) from the
// Plotly JSON beside it, with the page's one config; everything it uses is in the page.
(function () {
  "use strict";
  var config = JSON.parse(document.getElementById("plotly-config").textContent);
  document.querySelectorAll("div.plotly-figure").forEach(function (div) {
    var spec = JSON.parse(document.getElementById(div.dataset.spec).textContent);
    Plotly.newPlot(div, spec.data, spec.layout, config);
  });
})();
