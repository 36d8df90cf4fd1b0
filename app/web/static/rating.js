/* facepair rating pages: the rating design (play one face, rate it on the five ACR levels,
 * keys 5 to 1, or on the 0-100 slider) and the parallel design (play the reference and every
 * numbered version of a clip, rate each on its slider, Next once each was played and rated).
 *
 * As a vote (static/pair.js, with the helpers of static/participant.js, which runs first and
 * lends them as window.facepairVotes and window.facepairText): the answer is kept in
 * localStorage until the server has it, every resend carries the same idempotency key, and
 * only a 5xx or a lost connection is sent again. The answer carries the next clip, which
 * replaces the rated one in place (nextRater), as the next pair replaces a voted one: no page
 * is loaded between clips. */
(function () {
  "use strict";

  var first = document.querySelector(".rater");
  var shared = window.facepairVotes;
  if (!first || !shared) return;
  var T = window.facepairText.strings;
  var fmt = window.facepairText.format;
  var coarse = window.matchMedia && window.matchMedia("(pointer: coarse)").matches;

  // The rater on screen; a rated clip's answer replaces it with the next clip's (nextRater).
  var current = null;

  function Rater(root, pristine) {
    var self = this;
    var parallel = root.classList.contains("parallel");
    var d = root.dataset;
    var video = root.querySelector("video");
    var overlay = root.querySelector(".overlay");
    var overlayText = root.querySelector(".overlay-text");
    var loading = root.querySelector(".loading");
    var hint = root.querySelector(".hint");
    var status = root.querySelector(".status");
    var next = root.querySelector(".next");
    var pendingName = "fp-pending-rating-" + d.token;
    var media = new shared.MediaLog(video);
    // The clip from the first rendition this browser plays (static/participant.js); a browser
    // that plays none ends the session.
    var clip = new shared.ClipSource(video, function () {
      overlayText.textContent = T.load_retry;
    }, function () { if (!retired) shared.endUnplayable(d.unplayableUrl); });
    var state = { playing: false, plays: parseInt(d.plays || "0", 10), watched: false,
                  firstPlay: null, presentedAt: null, sent: false, requesting: false, attempt: 0 };
    // Replaced by the next clip's rater: nothing more is sent from this one.
    var retired = false;
    self.state = state;
    self.media = media;
    self.retire = function () { retired = true; };

    function say(text, kind) {
      status.textContent = text;
      status.className = "status" + (kind ? " status-" + kind : "");
      document.body.style.paddingTop = kind === "offline" ? status.offsetHeight + "px" : "";
    }

    // --- sending, as a vote is sent ---------------------------------------------------------
    var page = null;
    function send(payload) {
      if (retired) return;
      shared.post(d.ratingUrl, payload, function (action, body, retryAfter) {
        if (action === "retry") {
          state.attempt += 1;
          var wait = shared.wait(state.attempt, retryAfter);
          say(fmt(T.offline_rating, { seconds: Math.round(wait / 1000) }), "offline");
          shared.later(wait, function () { send(payload); });
          return;
        }
        shared.store(pendingName, null);
        if (action === "saved") {
          say(T.saved, "ok");
          // The answer carries the next clip (as its page would show it): the rater goes on in
          // place. Without it (the last clip, a missed check) the trial page is loaded;
          // replace: the back button never returns to a rated clip.
          if (!(body.next_trial && nextRater(self, root, pristine, body))) {
            window.location.replace(d.nextUrl);
          }
        } else if (action === "closed") {
          say(fmt(T.closed, { reason: body.message || T.study_closed }), "error");
        } else {
          state.sent = false;
          say(parallel ? T.refused_parallel : T.refused_rating, "error");
          if (page) page.update();
        }
      });
    }

    // The rating with the trial's facts; `answer` holds `score` or `scores`.
    function submit(answer) {
      state.sent = true;
      video.pause();
      if (page) page.update();
      hint.textContent = "";
      say(T.saving);
      var payload = {
        token: d.token, trial_id: parseInt(d.trialId, 10), plays: state.plays,
        watched_to_end: state.watched,
        response_ms: state.firstPlay === null ? null :
          Math.round(performance.now() - state.firstPlay),
        presented_at: state.presentedAt, idempotency_key: shared.newKey(), media: media.report()
      };
      for (var key in answer) payload[key] = answer[key];
      shared.store(pendingName, payload);
      send(payload);
    }

    // --- playing -----------------------------------------------------------------------------
    // Each play is asked of the server first (the replay policy holds across reloads); `go`
    // starts it, `refused` runs when no play is left.
    function askPlay(go, refused) {
      state.requesting = true;
      shared.requestPlay(d.playUrl, d.token, parseInt(d.trialId, 10), function (plays) {
        state.requesting = false;
        state.plays = plays === null ? state.plays + 1 : plays;
        go();
      }, function (plays) {
        state.requesting = false;
        if (plays !== null) state.plays = plays;
        refused();
      });
    }

    function start() {
      shared.playFromStart(video, media, state, overlay, function () {
        if (page) page.update();
      }, function () {
        // The parallel page has no Play button: the version's own button starts it.
        overlayText.textContent = parallel ?
          (coarse ? T.parallel_start_tap : T.parallel_start_press) :
          (coarse ? T.start_tap : T.start_press);
      });
    }

    video.addEventListener("pause", function () {
      if (!video.ended) { state.playing = false; if (page) page.update(); }
    });

    // --- the rating design: one face ---------------------------------------------------------
    function singlePage() {
      var playButton = root.querySelector(".play");
      var playsLeft = root.querySelector(".plays-left");
      var levels = root.querySelectorAll(".level");
      var slider = root.querySelector("input[type=range]");
      var maxPlays = d.maxPlays ? parseInt(d.maxPlays, 10) : null;
      var needsEnd = d.needsEnd === "yes";
      var loaded = false, moved = false;

      function mayPlay() {
        if (!loaded || state.playing || state.sent || state.requesting) return false;
        return !(maxPlays !== null && state.plays >= maxPlays);
      }
      // As for votes: plays granted before a reload count as seen.
      function mayRate() {
        if (state.sent || state.plays === 0) return false;
        return needsEnd ? state.watched : true;
      }
      function update() {
        playButton.disabled = !mayPlay();
        var again = state.plays > 1 || (state.plays === 1 && !state.playing);
        playButton.firstChild.nodeValue = (again ? T.play_again : T.play) + " ";
        for (var i = 0; i < levels.length; i++) levels[i].disabled = !mayRate();
        if (slider) slider.disabled = !mayRate();
        if (next) next.disabled = !(mayRate() && moved);
        if (maxPlays !== null && loaded) {
          var left = Math.max(0, maxPlays - state.plays);
          playsLeft.textContent = (T.plays_left || [])[left] || String(left);
        }
        if (state.sent || !loaded) return;
        if (!mayRate()) {
          hint.textContent = state.firstPlay === null ?
            (coarse ? T.hint_watch_tap : T.hint_watch_press) : T.hint_to_end;
        } else hint.textContent = slider ? T.hint_slider : T.hint_rate;
      }
      function load() {
        if (retired) return;  // a retry timer of a clip rated before it loaded
        clip.show(d.videoUrl, d.webmUrl);
      }
      video.addEventListener("loadeddata", function () {
        if (loaded) return;
        loaded = true;
        state.presentedAt = new Date().toISOString();
        overlayText.textContent = mayPlay() ? (coarse ? T.ready_tap : T.ready_press) :
          T.please_answer;
        loading.hidden = true;
        update();
        playButton.focus();
        // While this clip is rated, the next one comes into the browser's cache, in the
        // rendition this one plays in.
        var preload = clip.type() === shared.WEBM && d.preloadWebmUrl ? d.preloadWebmUrl :
          d.preloadUrl;
        if (preload && window.fetch) {
          fetch(preload, { credentials: "same-origin" }).then(function (r) {
            return r.blob();
          }).catch(function () { /* fetched again when it is shown */ });
        }
      });
      video.addEventListener("progress", function () {
        var percent = shared.buffered(video);
        if (loaded || percent === null) return;
        loading.value = percent;
        overlayText.textContent = fmt(T.loading_percent, { percent: percent });
      });
      video.addEventListener("ended", function () {
        state.playing = false;
        state.watched = true;
        overlay.hidden = false;
        overlayText.textContent = mayPlay() ? (coarse ? T.again_tap : T.again_press) :
          T.please_answer;
        update();
        var first = slider || root.querySelector(".level:not([disabled])");
        if (first && document.activeElement === playButton) first.focus();
      });
      function play() {
        if (!mayPlay()) return;
        update();
        askPlay(start, function () { say(T.no_more_plays, "error"); update(); });
        update();
      }
      function choose(button) {
        if (!button || !mayRate()) return;
        for (var i = 0; i < levels.length; i++) {
          levels[i].classList.toggle("chosen", levels[i] === button);
          levels[i].setAttribute("aria-pressed", levels[i] === button ? "true" : "false");
        }
        submit({ score: parseInt(button.dataset.score, 10) });
      }
      playButton.addEventListener("click", play);
      for (var i = 0; i < levels.length; i++) {
        levels[i].addEventListener("click", function (e) { choose(e.currentTarget); });
      }
      if (slider) {
        slider.addEventListener("input", function () { moved = true; update(); });
        next.addEventListener("click", function () {
          if (moved && mayRate()) submit({ score: parseInt(slider.value, 10) });
        });
      }
      return {
        update: update,
        begin: function () { update(); load(); },
        play: play,
        key: function (key) {
          if (!levels.length || !/^[1-5]$/.test(key)) return false;
          choose(root.querySelector('.level[data-score="' + key + '"]'));
          return true;
        }
      };
    }

    // --- the parallel design: every version of one clip, and the reference -------------------
    function parallelPage() {
      var buttons = root.querySelectorAll(".item-play");
      var sliders = root.querySelectorAll("input[type=range]");
      var played = {}, moved = {}, shownItem = null, shownUrl = null;

      function complete() {
        for (var i = 0; i < sliders.length; i++) {
          if (!played[i] || !moved[i]) return false;
        }
        return true;
      }
      function update() {
        for (var i = 0; i < buttons.length; i++) {
          var item = buttons[i].dataset.item;
          // Not disabled while a play is asked for (playItem ignores a press meanwhile): a
          // disabled button loses the keyboard's focus, and the Tab key its place.
          buttons[i].disabled = state.sent;
          buttons[i].classList.toggle("played", Boolean(played[item]));
          buttons[i].classList.toggle("playing", state.playing && shownItem === item);
        }
        for (var j = 0; j < sliders.length; j++) sliders[j].disabled = state.sent;
        next.disabled = state.sent || !complete();
        if (!state.sent) hint.textContent = complete() ? T.hint_parallel_done : T.hint_parallel;
      }
      function playItem(item) {
        if (state.sent || state.requesting) return;
        update();
        askPlay(function () {
          shownItem = item;
          var url = item === "reference" ? d.referenceUrl : d.itemUrl + item;
          var webm = !d.itemWebmUrl ? null :
            item === "reference" ? d.referenceWebmUrl : d.itemWebmUrl + item;
          // the version on screen is played again as it is; another is asked for
          if (shownUrl !== url) {
            shownUrl = url;
            clip.show(url, webm);
          }
          start();
        }, function () { say(T.no_more_plays, "error"); update(); });
        update();
      }
      video.addEventListener("playing", function () {
        if (shownItem !== null && shownItem !== "reference") played[shownItem] = true;
        if (state.presentedAt === null) state.presentedAt = new Date().toISOString();
        update();
      });
      video.addEventListener("ended", function () {
        state.playing = false;
        state.watched = true;
        update();
      });
      for (var i = 0; i < buttons.length; i++) {
        buttons[i].addEventListener("click", function (e) {
          playItem(e.currentTarget.dataset.item);
        });
      }
      for (var j = 0; j < sliders.length; j++) {
        sliders[j].addEventListener("input", function (e) {
          moved[e.currentTarget.dataset.item] = true;
          update();
        });
      }
      next.addEventListener("click", function () {
        if (state.sent || !complete()) return;
        var scores = Array.prototype.map.call(sliders, function (s) {
          return parseInt(s.value, 10);
        });
        submit({ scores: scores });
      });
      return {
        update: update,
        begin: function () {
          overlayText.textContent = coarse ? T.hint_parallel_start_tap :
            T.hint_parallel_start_press;
          loading.hidden = true;
          update();
        },
        play: function () { playItem(shownItem === null ? "reference" : shownItem); },
        key: function () { return false; }
      };
    }

    page = parallel ? parallelPage() : singlePage();
    self.play = function () { page.play(); };
    self.key = function (key) { return page.key(key); };

    // A rating kept from before a reload (e.g. sent while offline) goes out first, unchanged.
    var kept = shared.load(pendingName);
    if (kept && String(kept.trial_id) === d.trialId) {
      state.sent = true;
      say(T.sending_kept);
      send(kept);
      page.update();
      return;
    }
    if (kept) shared.store(pendingName, null);
    page.begin();
  }

  // The next clip in place of the one just rated: a copy of the rater as the server rendered
  // it (taken before it ran) with the next trial's attributes, the bar's progress and, for a
  // check, its instruction; what the trial page would show, without loading it.
  function nextRater(caller, root, pristine, body) {
    if (current !== caller) return true;  // an answer for a rater already replaced
    var next = body.next_trial;
    var fresh = pristine.cloneNode(true);
    var d = fresh.dataset;
    if (fresh.classList.contains("parallel")) {
      // a page with another number of versions is the server's to draw
      if (next.items !== fresh.querySelectorAll("input[type=range]").length) return false;
      d.referenceUrl = next.reference_url;
      d.itemUrl = next.item_url;
      if (next.item_webm_url) {
        d.referenceWebmUrl = next.reference_webm_url;
        d.itemWebmUrl = next.item_webm_url;
      } else {
        delete d.referenceWebmUrl;
        delete d.itemWebmUrl;
      }
    } else {
      d.videoUrl = next.video_url;
      if (next.webm_url) d.webmUrl = next.webm_url;
      else delete d.webmUrl;
      if (next.preload_url) d.preloadUrl = next.preload_url;
      else delete d.preloadUrl;
      if (next.preload_webm_url) d.preloadWebmUrl = next.preload_webm_url;
      else delete d.preloadWebmUrl;
    }
    d.trialId = String(next.trial_id);
    d.plays = String(next.plays);
    caller.retire();
    shared.showInPlace(
      root, fresh, fmt(T.clip_of, { number: body.answered + 1, total: body.total }),
      body.answered, body.total,
      next.catch ? { sentence: T.catch_rating, slot: "%(level)s", word: T.catch_level } : null
    );
    current = new Rater(fresh, pristine);
    return true;
  }

  // A pristine copy for the next clip, taken before the rater runs.
  current = new Rater(first, first.cloneNode(true));

  document.addEventListener("keydown", function (e) {
    if (e.altKey || e.ctrlKey || e.metaKey) return;
    var tag = (e.target && e.target.tagName) || "";
    if (e.key === " " || e.key === "p" || e.key === "P") {
      if (e.key === " " && (tag === "BUTTON" || tag === "INPUT")) return;
      e.preventDefault();
      current.play();
    } else if (current.key(e.key)) {
      e.preventDefault();
    }
  });
  // Leaving the window or the tab while a clip is on screen is part of its media log.
  function lostFocus() { if (!current.state.sent) current.media.focusLost(); }
  window.addEventListener("blur", lostFocus);
  document.addEventListener("visibilitychange", function () {
    if (document.visibilityState === "hidden") lostFocus();
  });
})();
