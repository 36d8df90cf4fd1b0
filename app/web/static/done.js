/* facepair done page: the completion code waits for every answer (one kept from a lost
 * connection goes first), then the page goes back to the study platform. It runs after
 * participant.js (the answers kept in localStorage). */
(function () {
  "use strict";

  var store = window.facepairVotes.store, load_ = window.facepairVotes.load;
  var done = document.querySelector(".done[data-token]");
  var code = document.getElementById("completion-code");
  var pending = done ? load_("fp-pending-" + done.dataset.token) : null;
  // Back to the study platform after a few seconds (a script, not a meta refresh: the page
  // says so first, and a kept answer is sent before leaving); the button is there meanwhile.
  var back = document.getElementById("redirect");
  function sendBack() {
    if (back && back.dataset.redirectAfter) {
      setTimeout(function () { window.location.assign(back.href); },
                 1000 * Number(back.dataset.redirectAfter));
    }
  }
  if (pending && code) {
    code.hidden = true;
    fetch("/api/v1/votes", {
      method: "POST", credentials: "same-origin", cache: "no-store",
      headers: { "Content-Type": "application/json", Accept: "application/json" },
      body: JSON.stringify(pending)
    }).then(function (r) {
      if (r.status < 500) { store("fp-pending-" + done.dataset.token, null); code.hidden = false; }
      sendBack();
    });
  } else sendBack();
})();
