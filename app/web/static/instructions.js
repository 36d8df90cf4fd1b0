/* facepair instructions page: the start link reports the participant's screen, and the viewing
 * check holds the start back where each face would be shown too small. It runs after
 * participant.js (the page's words); the practice pair is pair.js's. */
(function () {
  "use strict";

  var startLink = document.getElementById("start");
  if (!startLink || !startLink.dataset.environmentUrl) return;
  var T = window.facepairText.strings, fmt = window.facepairText.format;

  startLink.addEventListener("click", function (e) {
    var stage = document.querySelector(".stage");
    var width = stage ? stage.clientWidth : document.querySelector("main").clientWidth;
    var facePx = Math.floor(width / 2);
    var minFace = parseInt(startLink.dataset.minFace || "0", 10);
    var report = {
      screen_w: screen.width, screen_h: screen.height, viewport_w: window.innerWidth,
      viewport_h: window.innerHeight, dpr: window.devicePixelRatio || 1,
      touch: navigator.maxTouchPoints > 0, face_px: facePx
    };
    var sent = fetch(startLink.dataset.environmentUrl, {
      method: "POST", credentials: "same-origin", cache: "no-store", keepalive: true,
      headers: { "Content-Type": "application/json", Accept: "application/json" },
      body: JSON.stringify(report)
    });
    // Without a viewing check the link is followed at once; the report goes out alongside.
    if (!minFace) return;
    e.preventDefault();
    function go() { window.location.assign(startLink.href); }
    sent.then(function (r) { return r.json(); }).then(function (body) {
      if (body.viewing_ok === false) {
        var message = document.querySelector(".viewing-check");
        message.textContent = fmt(T.viewing_small, { shown: facePx, needed: minFace });
        message.hidden = false;
        message.scrollIntoView();
      } else go();
    }, go);
  });
})();
