/* facepair pair player (the trial page and the instructions' practice pair): preload, replay
 * policy, votes by buttons and keys, offline retry, the next pair in place. It runs after
 * participant.js, whose helpers it takes from window.facepairVotes.
 *
 * A vote is kept in localStorage until the server has it, so neither a lost connection nor a
 * reload loses it; every resend carries the same idempotency key, so it is stored once. */
(function () {
  "use strict";

  var votes = window.facepairVotes;
  if (!votes) return;
  var MediaLog = votes.MediaLog, ClipSource = votes.ClipSource, WEBM = votes.WEBM;
  var store = votes.store, load_ = votes.load, newKey = votes.newKey;
  var postAnswer = votes.post, retryWait = votes.wait, resendLater = votes.later;
  var requestPlay = votes.requestPlay, playFromStart = votes.playFromStart;
  var bufferedPercent = votes.buffered, endUnplayable = votes.endUnplayable;
  var showInPlace = votes.showInPlace;
  var T = window.facepairText.strings, fmt = window.facepairText.format;

  function sideName(choice) { return (T.choices && T.choices[choice]) || choice; }
  var coarse = window.matchMedia && window.matchMedia("(pointer: coarse)").matches;
  // What the participant does to the Play button: a touch screen is tapped.
  function byPointer(tap, press) { return coarse ? T[tap] : T[press]; }

  function Player(root) {
    var d = root.dataset;
    var self = this;
    var video = root.querySelector("video");
    var playButton = root.querySelector(".play");
    var voteButtons = root.querySelectorAll(".vote");
    var overlay = root.querySelector(".overlay");
    var overlayText = root.querySelector(".overlay-text");
    var loading = root.querySelector(".loading");
    var hint = root.querySelector(".hint");
    var status = root.querySelector(".status");
    var playsLeft = root.querySelector(".plays-left");
    var reasons = root.querySelector(".reasons");
    var practice = d.practice === "yes";
    // The server's rules (app.trials.rules): the play cap, whether a vote waits for the end,
    // and the keys that cast a choice besides each button's own key.
    var maxPlays = d.maxPlays ? parseInt(d.maxPlays, 10) : null;
    var needsEnd = d.needsEnd === "yes";
    var keys = JSON.parse(d.keys || "{}");
    var pendingName = d.token ? "fp-pending-" + d.token : null;
    // Plays the server already granted: a reload gives none back.
    var state = { loaded: false, playing: false, plays: parseInt(d.plays || "0", 10),
                  watched: false, firstPlay: null, presentedAt: null, voted: false,
                  attempt: 0, choice: null, strength: null, requesting: false };
    var media = new MediaLog(video);

    self.root = root;
    self.active = function () { return !state.voted; };
    self.media = media;

    function mayPlay() {
      if (!state.loaded || state.playing || state.voted || state.requesting) return false;
      return !(maxPlays !== null && state.plays >= maxPlays);
    }

    // Plays granted before this page was loaded (the server's count, data-plays) count as seen:
    // after a reload the participant may answer without a play, so that using up the plays of
    // a max_plays pair is never a dead end. Only play_to_end waits for a play seen to its end
    // here, and it never runs out of plays.
    function mayVote() {
      if (state.voted || state.plays === 0) return false;
      if (needsEnd) return state.watched;
      return true;
    }

    function update() {
      playButton.disabled = !mayPlay();
      // "Play again" once a play is over (or while a later one runs), never during the first.
      var again = state.plays > 1 || (state.plays === 1 && !state.playing);
      playButton.firstChild.nodeValue = (again ? T.play_again : T.play) + " ";
      for (var i = 0; i < voteButtons.length; i++) voteButtons[i].disabled = !mayVote();
      if (maxPlays !== null && state.loaded) {
        var left = Math.max(0, maxPlays - state.plays);
        playsLeft.textContent = (T.plays_left || [])[left] || String(left);
      }
      if (state.voted || !state.loaded) return;
      if (state.firstPlay === null && !mayVote()) {
        hint.textContent = byPointer("hint_tap", "hint_press");
      } else if (!mayVote()) hint.textContent = T.hint_to_end;
      else if (state.firstPlay === null && !mayPlay()) {
        hint.textContent = T.hint_used;
      } else hint.textContent = d.undecided === "yes" ? T.hint_choose_undecided : T.hint_choose;
    }

    function ready() {
      if (state.loaded) return;
      state.loaded = true;
      state.presentedAt = new Date().toISOString();
      overlayText.textContent = mayPlay() ? byPointer("ready_tap", "ready_press") : T.please_answer;
      loading.hidden = true;
      update();
      if (!practice) playButton.focus();
      // While this pair is judged, the next clip comes into the browser's cache, in the
      // rendition this one plays in.
      var preload = clip.type() === WEBM && d.preloadWebmUrl ? d.preloadWebmUrl : d.preloadUrl;
      if (preload && window.fetch) {
        fetch(preload, { credentials: "same-origin" }).then(function (r) {
          return r.blob();
        }).catch(function () { /* fetched again when its page opens */ });
      }
    }

    // The clip streams (HTTP ranges): play may start before it is all here, and a slow
    // connection shows how much has arrived rather than a black box.
    function showProgress() {
      var percent = bufferedPercent(video);
      if (state.loaded || percent === null) return;
      loading.value = percent;
      overlayText.textContent = fmt(T.loading_percent, { percent: percent });
    }

    var clip = new ClipSource(video, function () {
      overlayText.textContent = T.load_retry;
    }, function () { endUnplayable(d.unplayableUrl); });
    function load() { clip.show(d.videoUrl, d.webmUrl); }
    video.addEventListener("progress", showProgress);
    video.addEventListener("loadeddata", ready);

    function start() {
      playFromStart(video, media, state, overlay, update, function () {
        overlayText.textContent = byPointer("start_tap", "start_press");
      });
    }

    self.play = function () {
      if (!mayPlay()) return;
      if (practice || !d.playUrl) { state.plays += 1; start(); return; }
      // Each play is asked of the server first, so the count survives a reload; offline the
      // clip is here, so it plays, and the vote carries the page's count.
      state.requesting = true;
      update();
      requestPlay(d.playUrl, d.token, parseInt(d.trialId, 10), function (plays) {
        state.requesting = false;
        state.plays = plays === null ? state.plays + 1 : plays;
        start();
      }, function (plays) {
        state.requesting = false;
        if (plays !== null) state.plays = plays;
        say(T.no_more_plays, "error");
        update();
      });
    };

    video.addEventListener("ended", function () {
      state.playing = false;
      state.watched = true;
      overlay.hidden = false;
      overlayText.textContent = mayPlay() ? byPointer("again_tap", "again_press") : T.please_answer;
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
      // The offline banner is pinned to the top of the window: the page moves down by its
      // height, so it never covers the question or the progress bar.
      document.body.style.paddingTop = kind === "offline" ? status.offsetHeight + "px" : "";
    }

    function retryLater(payload, retryAfter) {
      state.attempt += 1;
      var wait = retryWait(state.attempt, retryAfter);
      say(fmt(T.offline, { choice: sideName(payload.choice), seconds: Math.round(wait / 1000) }),
          "offline");
      resendLater(wait, function () { send(payload); });
    }

    // Replaced by the next pair's player: nothing more is sent from this one.
    var retired = false;
    self.retire = function () { retired = true; };

    function send(payload) {
      if (retired) return;
      postAnswer(d.voteUrl, payload, function (action, body, retryAfter) {
        if (action === "retry") return retryLater(payload, retryAfter);
        store(pendingName, null);
        if (action === "saved") {
          say(T.saved, "ok");
          // The answer carries the next pair (as its trial page would show it): the player
          // goes on in place. Without it (the last pair, or a case the server decides on the
          // page), the trial page is loaded; replace: the back button never returns to an
          // answered pair.
          if (!(body.next_trial && self.onNext && self.onNext(self, body))) {
            window.location.replace(d.nextUrl);
          }
        } else if (action === "closed") {
          // Final: the study (or this participant's session) stopped taking answers.
          // Nothing is resent; the server's reason is shown (its words for people).
          say(fmt(T.closed, { reason: body.message || T.study_closed }), "error");
        } else {
          // Refused for a reason the participant can act on (e.g. the replay policy).
          state.voted = false;
          say(T.refused, "error");
          update();
        }
      });
    }

    function mark(button) {
      for (var i = 0; i < voteButtons.length; i++) {
        voteButtons[i].classList.toggle("chosen", voteButtons[i] === button);
        voteButtons[i].setAttribute("aria-pressed", voteButtons[i] === button ? "true" : "false");
      }
    }

    function submit() {
      state.voted = true;
      video.pause();
      for (var i = 0; i < voteButtons.length; i++) voteButtons[i].disabled = true;
      playButton.disabled = true;
      if (reasons) reasons.hidden = true;
      if (practice) {
        say(fmt(T.practice_answer, { choice: sideName(state.choice) }), "ok");
        var startLink = document.getElementById("start");
        if (startLink) startLink.focus();
        return;
      }
      hint.textContent = "";
      say(T.saving);
      var payload = {
        token: d.token, trial_id: parseInt(d.trialId, 10), choice: state.choice,
        plays: state.plays, watched_to_end: state.watched,
        // Unknown when every play was before a reload (the answer came without one here).
        response_ms: state.firstPlay === null ? null :
          Math.round(performance.now() - state.firstPlay),
        presented_at: state.presentedAt, idempotency_key: newKey(), media: media.report()
      };
      if (d.scale === "5") payload.strength = state.strength;
      if (reasons) {
        payload.reasons = Array.prototype.filter.call(
          reasons.querySelectorAll("input"), function (box) { return box.checked; }
        ).map(function (box) { return box.value; });
      }
      store(pendingName, payload);
      send(payload);
    }

    self.vote = function (button) {
      if (!button || !mayVote()) return;
      state.choice = button.dataset.choice;
      state.strength = button.dataset.strength ? parseInt(button.dataset.strength, 10) : null;
      mark(button);
      if (!reasons) return submit();
      // Reason tags first; the choice can still change until Next.
      reasons.hidden = false;
      hint.textContent = T.hint_reasons;
      // The tags and their Next button may lie below the fold: brought into view, or the
      // participant sees nothing happen.
      if (reasons.scrollIntoView) reasons.scrollIntoView({ block: "nearest" });
    };
    self.key = function (key) {
      var button = root.querySelector('.vote[data-key="' + key + '"]');
      if (!button && Object.prototype.hasOwnProperty.call(keys, key)) {
        button = root.querySelector('.vote[data-choice="' + keys[key] + '"]');
      }
      if (button) self.vote(button);
      return Boolean(button);
    };

    playButton.addEventListener("click", self.play);
    for (var i = 0; i < voteButtons.length; i++) {
      voteButtons[i].addEventListener("click", function (e) { self.vote(e.currentTarget); });
    }
    if (reasons) {
      reasons.querySelector(".confirm").addEventListener("click", function () {
        if (!state.voted && state.choice) submit();
      });
    }

    // A vote kept from before a reload (e.g. sent while offline) goes out first, unchanged.
    var kept = pendingName ? load_(pendingName) : null;
    if (kept && String(kept.trial_id) === d.trialId) {
      state.voted = true;
      update();
      say(T.sending_kept);
      send(kept);
      return;
    }
    if (kept) store(pendingName, null);
    update();
    load();
  }

  // The next pair in place of the one just answered: a copy of the player as the server
  // rendered it (taken before it ran), with the next trial's attributes, and the bar's
  // progress; what the trial page would show, without loading it.
  function nextPlayer(pristine, index, caller, body) {
    // Only the player on screen goes on (an answer for one already replaced is not news).
    if (players[index] !== caller) return true;
    caller.retire();
    var next = body.next_trial;
    var root = caller.root;
    var fresh = pristine.cloneNode(true);
    var d = fresh.dataset;
    d.trialId = String(next.trial_id);
    d.plays = String(next.plays);
    d.videoUrl = next.video_url;
    if (next.webm_url) d.webmUrl = next.webm_url;
    else delete d.webmUrl;
    if (next.preload_url) d.preloadUrl = next.preload_url;
    else delete d.preloadUrl;
    if (next.preload_webm_url) d.preloadWebmUrl = next.preload_webm_url;
    else delete d.preloadWebmUrl;
    showInPlace(
      root, fresh, fmt(T.pair_of, { number: body.answered + 1, total: body.total }),
      body.answered, body.total,
      next.instructed ?
        { sentence: T.instructed, slot: "%(side)s", word: sideName(next.instructed) } : null
    );
    players[index] = makePlayer(fresh, pristine, index);
    return true;
  }

  function makePlayer(root, pristine, index) {
    var player = new Player(root);
    if (pristine) {
      player.onNext = function (caller, body) { return nextPlayer(pristine, index, caller, body); };
    }
    return player;
  }

  var players = Array.prototype.map.call(document.querySelectorAll(".player"), function (root, i) {
    // Trial players only (the practice has no trial id): a pristine copy for the next pair.
    return makePlayer(root, root.dataset.trialId ? root.cloneNode(true) : null, i);
  });

  function current() { return players.filter(function (p) { return p.active(); })[0]; }

  // Leaving the window while a pair is on screen is part of its media log.
  function lostFocus() { var player = current(); if (player) player.media.focusLost(); }
  window.addEventListener("blur", lostFocus);
  document.addEventListener("visibilitychange", function () {
    if (document.visibilityState === "hidden") lostFocus();
  });

  document.addEventListener("keydown", function (e) {
    if (e.altKey || e.ctrlKey || e.metaKey) return;
    var tag = (e.target && e.target.tagName) || "";
    if (tag === "INPUT" || tag === "TEXTAREA" || tag === "SELECT") return;
    var player = current();
    if (!player) return;
    if (e.key === " " || e.key === "p" || e.key === "P") {
      // Space on a focused button activates that button itself.
      if (e.key === " " && tag === "BUTTON") return;
      e.preventDefault();
      player.play();
    } else if (player.key(e.key)) {
      e.preventDefault();
    }
  });
})();
