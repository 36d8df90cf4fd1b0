/* facepair participant player: preload, replay policy, votes by buttons and keys, offline retry.
 *
 * A vote is kept in localStorage until the server has it, so neither a lost connection nor a
 * reload loses it; every resend carries the same idempotency key, so it is stored once. */
(function () {
  "use strict";

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

  function load_(name) {
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


  // The media log of one trial: what was seen, not only what was answered.
  function MediaLog(video) {
    var log = { watched_ms: 0, played_to_end: false, stalls: 0, stall_ms: 0, focus_lost: 0,
                pauses: 0, seeks: 0, stall_durations: [] };
    // A stall is playback running dry: a `waiting` after frames have been shown, not the
    // wait that every play (and its seek back to the start) begins with.
    var lastTime = null, stallStart = null, flowing = false;
    function endStall() {
      if (stallStart === null) return;
      var ms = Math.round(performance.now() - stallStart);
      stallStart = null;
      log.stall_ms += ms;
      if (log.stall_durations.length < 50) log.stall_durations.push(ms);
    }
    video.addEventListener("timeupdate", function () {
      var now = video.currentTime;
      // Only forward steps of ordinary playback count as watched (not seeks or restarts).
      if (lastTime !== null && !video.paused && now > lastTime && now - lastTime < 1.5) {
        log.watched_ms += Math.round(1000 * (now - lastTime));
      }
      lastTime = now;
    });
    video.addEventListener("seeking", function () { lastTime = null; flowing = false; });
    video.addEventListener("waiting", function () {
      if (stallStart === null && flowing && !video.seeking && !video.ended) {
        log.stalls += 1;
        stallStart = performance.now();
      }
    });
    video.addEventListener("playing", function () { endStall(); flowing = true; });
    video.addEventListener("pause", function () { endStall(); if (!video.ended) log.pauses += 1; });
    video.addEventListener("ended", function () { endStall(); log.played_to_end = true; });
    this.seeked = function () { log.seeks += 1; };
    this.restarted = function () { lastTime = null; flowing = false; };
    this.focusLost = function () { log.focus_lost += 1; };
    this.report = function () {
      endStall();
      log.width = Math.round(video.clientWidth);
      log.height = Math.round(video.clientHeight);
      return log;
    };
  }

  // POST `payload` as JSON to `url`; `outcome(action, body, retryAfter)` with the action of
  // voteAction (a lost connection reads as "retry").
  function postAnswer(url, payload, outcome) {
    fetch(url, {
      method: "POST",
      headers: { "Content-Type": "application/json", Accept: "application/json" },
      body: JSON.stringify(payload),
      credentials: "same-origin",
      cache: "no-store"
    }).then(function (response) {
      return response.json().catch(function () { return {}; }).then(function (body) {
        outcome(voteAction(response.status, body), body, response.headers.get("Retry-After"));
      });
    }, function () { outcome("retry", {}, null); });
  }

  // `again` once, after `wait` ms or when the connection comes back, whichever is first: the
  // other is called off, so no resend is left behind for a later trial.
  function resendLater(wait, again) {
    var timer = null;
    function once() {
      window.clearTimeout(timer);
      window.removeEventListener("online", once);
      again();
    }
    timer = window.setTimeout(once, wait);
    window.addEventListener("online", once);
  }

  // One play of a trial, asked of the server first (POST /api/v1/plays), so the count survives
  // a reload: `granted(plays)` when it may start, with the server's count, or null where the
  // server counted nothing (offline, or a 5xx: the clip is here, the page counts it);
  // `refused(plays)` when no play is left.
  function requestPlay(url, token, trialId, granted, refused) {
    fetch(url, {
      method: "POST", credentials: "same-origin", cache: "no-store",
      headers: { "Content-Type": "application/json", Accept: "application/json" },
      body: JSON.stringify({ token: token, trial_id: trialId })
    }).then(function (response) {
      return response.json().catch(function () { return {}; }).then(function (body) {
        var plays = typeof body.plays === "number" ? body.plays : null;
        if (response.status === 200) granted(plays);
        else if (response.status >= 500) granted(null);
        else refused(plays);
      });
    }, function () { granted(null); });
  }

  // A play from the start: the state's first play and the media log's restart noted, the
  // overlay hidden; `blocked` runs when the browser refuses to start (no gesture yet), and
  // `changed` after each change of state.
  function playFromStart(video, media, state, overlay, changed, blocked) {
    state.playing = true;
    if (state.firstPlay === null) state.firstPlay = performance.now();
    if (video.currentTime > 0) media.seeked();
    media.restarted();
    video.currentTime = 0;
    overlay.hidden = true;
    changed();
    var started = video.play();
    if (started && started.catch) started.catch(function () {
      state.playing = false;
      overlay.hidden = false;
      blocked();
      changed();
    });
  }

  // The renditions of a clip a page may offer (app.web.participant.renditions): the MP4
  // (H.264 + AAC), and where the clip has one its WebM (VP9 + Opus), for browsers without
  // H.264 (WebKitGTK without its codec plugins, some Linux builds of Firefox).
  var MP4 = 'video/mp4; codecs="avc1.640028, mp4a.40.2"';
  var WEBM = 'video/webm; codecs="vp9, opus"';

  // The renditions `video` may play, in the page's order (MP4, then WebM): those the browser
  // expects to play with their codecs first, then those it only knows the container of; a
  // rendition it rules out ("") is never asked for.
  function playable(video, mp4Url, webmUrl) {
    var offered = [{ url: mp4Url, type: MP4 }];
    if (webmUrl) offered.push({ url: webmUrl, type: WEBM });
    var sure = [], unsure = [];
    offered.forEach(function (source) {
      if (video.canPlayType(source.type)) sure.push(source);
      else if (video.canPlayType(source.type.split(";")[0])) unsure.push(source);
    });
    return sure.concat(unsure);
  }

  // Whether the server sent `url` (2xx, or a redirect to the media store): asked when the
  // browser refuses a clip as a format it cannot play, since a browser says the same of a
  // missing file or an error page. `answer(true | false)`; a lost connection is false.
  function served(url, answer) {
    fetch(url, {
      credentials: "same-origin", cache: "no-store", redirect: "manual",
      headers: { Range: "bytes=0-1" }
    }).then(function (response) {
      if (response.body && response.body.cancel) response.body.cancel().catch(function () {});
      answer(response.type === "opaqueredirect" || response.ok);
    }, function () { answer(false); });
  }

  // A clip played from the first of its renditions this browser can play. `show(mp4, webm)`
  // asks for a clip; one that fails before its first frame is asked for again after 2, 4, 8
  // ... seconds (at most 15; `retrying()` says so on the page), unless the server sent it and
  // the browser could not play it (MEDIA_ERR_SRC_NOT_SUPPORTED or MEDIA_ERR_DECODE): that is
  // final for this rendition, and the next one is tried. With none left `unplayable()` ends
  // the session, unless this browser has played one of these kinds of clip before (then a
  // clip it refuses is the server's trouble: asked for again, from the first). A player taken
  // off the page asks for nothing more.
  function ClipSource(video, retrying, unplayable) {
    var sources = [], index = 0, attempts = 0, ready = false, timer = null;
    var playedName = "fp-played-types";
    function load() {
      window.clearTimeout(timer);
      if (!video.isConnected) return;
      var source = sources[index];
      if (!source) { unplayable(); return; }
      video.preload = "auto";
      video.src = source.url;
      video.load();
    }
    function later() {
      attempts += 1;
      retrying();
      timer = window.setTimeout(load, Math.min(15000, 1000 * Math.pow(2, attempts)));
    }
    video.addEventListener("loadeddata", function () {
      ready = true;
      var played = load_(playedName) || {};
      if (sources[index] && !played[sources[index].type]) {
        played[sources[index].type] = true;
        store(playedName, played);
      }
    });
    video.addEventListener("error", function () {
      var source = sources[index];
      if (ready || !source || video.getAttribute("src") !== source.url) return;
      var code = video.error ? video.error.code : 0;
      if (code !== 3 && code !== 4) { later(); return; }
      served(source.url, function (sent) {
        if (!sent) { later(); return; }
        index += 1;
        attempts = 0;
        var played = load_(playedName) || {};
        var before = sources.some(function (s) { return played[s.type]; });
        if (index >= sources.length && before) {
          index = 0;
          later();
        } else load();
      });
    });
    this.show = function (mp4Url, webmUrl) {
      sources = playable(video, mp4Url, webmUrl);
      index = 0;
      attempts = 0;
      ready = false;
      load();
    };
    // The rendition being played: WEBM, MP4, or null before the first.
    this.type = function () { return sources[index] ? sources[index].type : null; };
  }

  // The browser plays none of a clip's renditions: the server ends the session (its list slot
  // goes to the next participant) and names the final page, which replaces this one. Sent
  // again, as a vote is, until the server has it; refused (a finished participant), nothing.
  function endUnplayable(url) {
    var attempt = 0;
    function again() {
      attempt += 1;
      resendLater(retryWait(attempt, null), send);
    }
    function send() {
      fetch(url, {
        method: "POST", credentials: "same-origin", cache: "no-store",
        headers: { Accept: "application/json" }
      }).then(function (response) {
        if (response.status >= 500) return again();
        return response.json().then(function (body) {
          if (response.ok && body.next) window.location.replace(body.next);
        });
      }, again);
    }
    send();
  }

  // How much of the clip has arrived, in percent, or null before the browser knows.
  function bufferedPercent(video) {
    if (!video.duration || !video.buffered.length) return null;
    return Math.round(100 * video.buffered.end(video.buffered.length - 1) / video.duration);
  }

  // The next trial on screen in place of the answered one (nextPlayer here, nextRater in
  // rating.js): `fresh` replaces `root`, the bar shows `progress` and `answered` of `total`,
  // and the check's `instruction` ({sentence, slot, word}: the word in bold where the language
  // puts its slot in the sentence; null: none) stands above it. The old clip's connection is
  // let go.
  function showInPlace(root, fresh, progress, answered, total, instruction) {
    var text = document.querySelector(".progress-text");
    if (text) text.textContent = progress;
    var bar = document.querySelector(".study-bar progress");
    if (bar) { bar.max = total; bar.value = answered; }
    var instructed = document.querySelector(".trial .instructed");
    if (instruction) {
      if (!instructed) {
        instructed = document.createElement("p");
        instructed.className = "instructed";
        root.parentNode.insertBefore(instructed, root);
      }
      var parts = String(instruction.sentence).split(instruction.slot);
      instructed.textContent = fmt(parts[0], {});
      var strong = document.createElement("strong");
      strong.textContent = instruction.word;
      instructed.appendChild(strong);
      instructed.appendChild(document.createTextNode(fmt(parts.slice(1).join(""), {})));
    } else if (instructed) {
      instructed.parentNode.removeChild(instructed);
    }
    var old = root.querySelector("video");
    old.pause();
    old.removeAttribute("src");
    old.load();
    root.parentNode.replaceChild(fresh, root);
    window.scrollTo(0, 0);  // where a loaded page starts (the reasons may have scrolled it)
  }

  // Shared with the rating pages' script (static/rating.js).
  window.facepairVotes = { action: voteAction, wait: retryWait, MediaLog: MediaLog, store: store,
                           load: load_, newKey: newKey, post: postAnswer, later: resendLater,
                           requestPlay: requestPlay, buffered: bufferedPercent,
                           playFromStart: playFromStart, ClipSource: ClipSource,
                           endUnplayable: endUnplayable, WEBM: WEBM,
                           showInPlace: showInPlace };

  // The page's words, in the study's language (app.web.study.wording.script_strings).
  var blob = document.getElementById("i18n");
  var T = blob ? JSON.parse(blob.textContent) : {};
  // A translated string with its %(name)s placeholders filled in (%% is one percent sign).
  function fmt(text, values) {
    return String(text || "").replace(/%\((\w+)\)[sd]|%%/g, function (all, name) {
      return name ? String(values[name]) : "%";
    });
  }
  function sideName(choice) { return (T.choices && T.choices[choice]) || choice; }
  window.facepairText = { format: fmt };

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
  // A page restored from the back-forward cache would show an answered pair: fetch it anew.
  window.addEventListener("pageshow", function (e) { if (e.persisted) window.location.reload(); });

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

  // The viewing check before the first trial: each face must be shown large enough.
  var startLink = document.getElementById("start");
  if (startLink && startLink.dataset.environmentUrl) {
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
  }

  // The audio check: the question's three sounds play once through, the one playing is
  // marked, and the answers open when they have all been heard (app.web.participant.audio).
  var audioCheck = document.querySelector(".audio-player");
  if (audioCheck) {
    var sounds = audioCheck.querySelector("audio");
    var playSounds = audioCheck.querySelector(".play-sounds");
    var choices = audioCheck.querySelectorAll(".sound-choice");
    var onsets = JSON.parse(audioCheck.dataset.onsets || "[]");
    var audioHint = audioCheck.querySelector(".hint");
    var mark = function (playing) {
      for (var c = 0; c < choices.length; c++) choices[c].classList.toggle("playing", c === playing);
    };
    playSounds.addEventListener("click", function () {
      playSounds.disabled = true;
      audioHint.textContent = T.audio_playing;
      sounds.currentTime = 0;
      var started = sounds.play();
      if (started && started.catch) started.catch(function () { playSounds.disabled = false; });
    });
    sounds.addEventListener("timeupdate", function () {
      var playing = -1;
      for (var o = 0; o < onsets.length; o++) {
        if (sounds.currentTime >= onsets[o] && sounds.currentTime < onsets[o] + 1) playing = o;
      }
      mark(playing);
    });
    sounds.addEventListener("ended", function () {
      mark(-1);
      playSounds.disabled = false;
      audioHint.textContent = T.audio_choose;
      for (var c = 0; c < choices.length; c++) choices[c].disabled = false;
      // On a small screen the answers may lie below the fold.
      if (choices[0].scrollIntoView) choices[0].scrollIntoView({ block: "nearest" });
    });
  }

  // The completion code waits for every answer: one kept from a lost connection goes first.
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
