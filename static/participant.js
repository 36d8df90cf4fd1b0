/* facepair participant player: preload, replay policy, votes by buttons and keys, offline retry.
 *
 * A vote is kept in localStorage until the server has it, so neither a lost connection nor a
 * reload loses it; every resend carries the same idempotency key, so it is stored once. */
(function () {
  "use strict";

  // The study file's convention: 1 = left, 2 = right, 0 = undecided; arrows work too.
  var KEYS = {
    ArrowLeft: "left", "1": "left",
    ArrowRight: "right", "2": "right",
    ArrowDown: "undecided", "0": "undecided"
  };

  function newKey() {
    if (window.crypto && window.crypto.randomUUID) return window.crypto.randomUUID();
    var bytes = new Uint8Array(16);
    window.crypto.getRandomValues(bytes);
    return Array.prototype.map.call(bytes, function (b) {
      return ("0" + b.toString(16)).slice(-2);
    }).join("");
  }

  function store(name, value) {
    try {
      if (value === null) window.localStorage.removeItem(name);
      else window.localStorage.setItem(name, JSON.stringify(value));
    } catch (e) { /* private mode: the page still holds the vote in memory */ }
  }

  function load(name) {
    try { return JSON.parse(window.localStorage.getItem(name) || "null"); } catch (e) { return null; }
  }

  // What the server's answer to a vote means: stored ("saved"), refused for good because the
  // study closed ("closed"), refused for another reason ("refused"), or worth sending again
  // ("retry": only 5xx, e.g. 503 while the database is unreachable). A 4xx is never resent.
  function voteAction(status, body) {
    if (status >= 200 && status < 300) return "saved";
    if (status >= 500) return "retry";
    if (body && body.closed) return "closed";
    return "refused";
  }

  // Milliseconds before resend number `attempt`: the server's Retry-After (seconds) if it
  // gave one, else exponential back-off; never more than 30 s.
  function retryWait(attempt, retryAfter) {
    var seconds = parseInt(retryAfter, 10);
    if (seconds >= 0) return Math.min(30000, 1000 * Math.max(1, seconds));
    return Math.min(30000, 1000 * Math.pow(2, attempt - 1));
  }

  window.facepairVotes = { action: voteAction, wait: retryWait };

  function Player(root) {
    var d = root.dataset;
    var self = this;
    var video = root.querySelector("video");
    var playButton = root.querySelector(".play");
    var voteButtons = root.querySelectorAll(".vote");
    var overlay = root.querySelector(".overlay");
    var overlayText = root.querySelector(".overlay-text");
    var hint = root.querySelector(".hint");
    var status = root.querySelector(".status");
    var playsLeft = root.querySelector(".plays-left");
    var practice = d.practice === "yes";
    var maxPlays = d.maxPlays ? parseInt(d.maxPlays, 10) : null;
    var pendingName = d.token ? "fp-pending-" + d.token : null;
    var state = { loaded: false, playing: false, plays: 0, watched: false, firstPlay: null,
                  presentedAt: null, voted: false, attempt: 0 };

    self.root = root;
    self.active = function () { return !state.voted; };

    function mayPlay() {
      if (!state.loaded || state.playing || state.voted) return false;
      return !(d.replay === "max_plays" && state.plays >= maxPlays);
    }

    function mayVote() {
      if (state.voted || state.plays === 0) return false;
      if (d.replay === "play_to_end") return state.watched;
      return true;
    }

    function update() {
      playButton.disabled = !mayPlay();
      playButton.firstChild.nodeValue = state.plays ? "Play again " : "Play ";
      for (var i = 0; i < voteButtons.length; i++) voteButtons[i].disabled = !mayVote();
      if (d.replay === "max_plays" && state.loaded) {
        var left = Math.max(0, maxPlays - state.plays);
        playsLeft.textContent = left + (left === 1 ? " play left" : " plays left");
      }
      if (state.voted) return;
      if (!state.loaded) return;
      if (state.plays === 0) hint.textContent = "Press Play (or Space) to watch both faces.";
      else if (!mayVote()) hint.textContent = "Watch the video to the end, then answer.";
      else hint.textContent = "Choose the left or the right face" +
        (d.undecided === "yes" ? ", or that you cannot decide" : "") + ".";
    }

    function preload(attempt) {
      var xhr = new XMLHttpRequest();
      xhr.open("GET", d.videoUrl);
      xhr.responseType = "blob";
      xhr.onprogress = function (e) {
        if (e.lengthComputable) overlayText.textContent =
          "Loading… " + Math.round(100 * e.loaded / e.total) + "%";
      };
      xhr.onload = function () {
        if (xhr.status !== 200) return retryLoad(attempt);
        video.src = URL.createObjectURL(xhr.response);
        video.addEventListener("loadeddata", function () {
          state.loaded = true;
          state.presentedAt = new Date().toISOString();
          overlayText.textContent = "Ready: press Play";
          update();
          if (!practice) playButton.focus();
        }, { once: true });
        video.load();
      };
      xhr.onerror = function () { retryLoad(attempt); };
      xhr.send();
    }

    function retryLoad(attempt) {
      overlayText.textContent = "Could not load the video, retrying…";
      window.setTimeout(function () { preload(attempt + 1); }, Math.min(15000, 1000 * Math.pow(2, attempt)));
    }

    self.play = function () {
      if (!mayPlay()) return;
      state.playing = true;
      state.plays += 1;
      if (state.firstPlay === null) state.firstPlay = performance.now();
      video.currentTime = 0;
      overlay.hidden = true;
      update();
      var started = video.play();
      if (started && started.catch) started.catch(function () {
        state.playing = false;
        state.plays -= 1;
        overlay.hidden = false;
        overlayText.textContent = "Press Play to start";
        update();
      });
    };

    video.addEventListener("ended", function () {
      state.playing = false;
      state.watched = true;
      overlay.hidden = false;
      overlayText.textContent = mayPlay() ? "Press Play to watch again" : "Please answer";
      update();
      var first = root.querySelector(".vote:not([disabled])");
      if (first && document.activeElement === playButton) first.focus();
    });
    video.addEventListener("pause", function () {
      if (!video.ended) { state.playing = false; update(); }
    });

    function say(text, kind) {
      status.textContent = text;
      status.className = "status" + (kind ? " status-" + kind : "");
    }

    function retryLater(payload, retryAfter) {
      state.attempt += 1;
      var wait = retryWait(state.attempt, retryAfter);
      say("No connection to the server. Your answer (" + payload.choice + ") is kept on " +
          "this page and will be sent automatically; please keep this page open. " +
          "Retrying in " + Math.round(wait / 1000) + " s…", "offline");
      var timer = window.setTimeout(function () { send(payload); }, wait);
      window.addEventListener("online", function () {
        window.clearTimeout(timer);
        send(payload);
      }, { once: true });
    }

    function send(payload) {
      var request = fetch(d.voteUrl, {
        method: "POST",
        headers: { "Content-Type": "application/json", Accept: "application/json" },
        body: JSON.stringify(payload),
        credentials: "same-origin",
        cache: "no-store"
      });
      request.then(function (response) {
        return response.json().catch(function () { return {}; }).then(function (body) {
          var action = voteAction(response.status, body);
          if (action === "retry") return retryLater(payload, response.headers.get("Retry-After"));
          store(pendingName, null);
          if (action === "saved") {
            say("Saved.", "ok");
            window.location.assign(d.nextUrl);
          } else if (action === "closed") {
            // Final: the study (or this participant's session) stopped taking answers.
            // Nothing is resent; the server's reason is shown.
            say("This answer could not be recorded: " + (body.error || "this study is closed") +
                ". Thank you for taking part.", "error");
          } else {
            // Refused for a reason the participant can act on (e.g. the replay policy).
            state.voted = false;
            say("Your answer was not accepted: " + (body.error || response.status), "error");
            update();
          }
        });
      }, function () { retryLater(payload, null); });
    }

    self.vote = function (choice) {
      if (!mayVote()) return;
      var button = root.querySelector('.vote[data-choice="' + choice + '"]');
      if (!button) return;
      state.voted = true;
      video.pause();
      for (var i = 0; i < voteButtons.length; i++) {
        voteButtons[i].disabled = true;
        voteButtons[i].classList.toggle("chosen", voteButtons[i] === button);
      }
      playButton.disabled = true;
      if (practice) {
        say("Practice answer: " + choice + ". That is all there is to it; start when ready.", "ok");
        var start = document.getElementById("start");
        if (start) start.focus();
        return;
      }
      hint.textContent = "";
      say("Saving your answer…");
      var payload = {
        token: d.token, trial_id: parseInt(d.trialId, 10), choice: choice, plays: state.plays,
        watched_to_end: state.watched,
        response_ms: Math.round(performance.now() - state.firstPlay),
        presented_at: state.presentedAt, idempotency_key: newKey()
      };
      store(pendingName, payload);
      send(payload);
    };

    playButton.addEventListener("click", self.play);
    for (var i = 0; i < voteButtons.length; i++) {
      voteButtons[i].addEventListener("click", function (e) {
        self.vote(e.currentTarget.dataset.choice);
      });
    }

    // A vote kept from before a reload (e.g. sent while offline) goes out first, unchanged.
    var kept = pendingName ? load(pendingName) : null;
    if (kept && String(kept.trial_id) === d.trialId) {
      state.voted = true;
      update();
      say("Sending the answer you gave before…");
      send(kept);
      return;
    }
    if (kept) store(pendingName, null);
    update();
    preload(0);
  }

  var players = Array.prototype.map.call(document.querySelectorAll(".player"), function (root) {
    return new Player(root);
  });

  document.addEventListener("keydown", function (e) {
    if (e.altKey || e.ctrlKey || e.metaKey) return;
    var tag = (e.target && e.target.tagName) || "";
    if (tag === "INPUT" || tag === "TEXTAREA" || tag === "SELECT") return;
    var player = players.filter(function (p) { return p.active(); })[0];
    if (!player) return;
    if (e.key === " " || e.key === "p" || e.key === "P") {
      // Space on a focused button activates that button itself.
      if (e.key === " " && tag === "BUTTON") return;
      e.preventDefault();
      player.play();
    } else if (KEYS[e.key]) {
      e.preventDefault();
      player.vote(KEYS[e.key]);
    }
  });
})();
