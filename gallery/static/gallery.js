// inkmotion gallery: filter the cards by kind, status and text. No network, no library;
// works from file://. The filters live in the address's #fragment, so a filtered view can
// be bookmarked or shared (e.g. index.html#kind=fit&status=succeeded&q=hello).
(function () {
  "use strict";
  var kind = document.getElementById("filter-kind");
  var status = document.getElementById("filter-status");
  var text = document.getElementById("filter-text");
  var count = document.getElementById("shown-count");
  var none = document.getElementById("no-match");
  var cards = Array.prototype.slice.call(document.querySelectorAll("#cards .card"));
  if (!kind || !status || !text) return;

  function readHash() {
    var params = new URLSearchParams(window.location.hash.replace(/^#/, ""));
    kind.value = params.get("kind") || "";
    status.value = params.get("status") || "";
    text.value = params.get("q") || "";
  }

  function writeHash() {
    var params = new URLSearchParams();
    if (kind.value) params.set("kind", kind.value);
    if (status.value) params.set("status", status.value);
    if (text.value) params.set("q", text.value);
    var hash = params.toString();
    if (("#" + hash) !== window.location.hash && !(hash === "" && window.location.hash === "")) {
      window.location.hash = hash;
    }
  }

  function apply() {
    var words = text.value.toLowerCase().split(/\s+/).filter(Boolean);
    var shown = 0;
    cards.forEach(function (card) {
      var ok = (!kind.value || card.dataset.kind === kind.value) &&
        (!status.value || card.dataset.status === status.value) &&
        words.every(function (w) { return card.dataset.search.indexOf(w) !== -1; });
      card.hidden = !ok;
      if (ok) shown += 1;
    });
    count.textContent = shown + " of " + cards.length + " jobs";
    if (none) none.hidden = shown !== 0 || cards.length === 0;
  }

  function changed() { apply(); writeHash(); }

  readHash();
  apply();
  kind.addEventListener("change", changed);
  status.addEventListener("change", changed);
  text.addEventListener("input", changed);
  window.addEventListener("hashchange", function () { readHash(); apply(); });
}());
