/* facepair participant pages: the shared library every participant page loads first, before
 * its own script (pair.js for the pairs, rating.js for the rating designs, instructions.js,
 * audio_check.js, done.js): answers sent and kept, plays asked of the server, the media log,
 * a clip's renditions, the next trial shown in place, and the page's words.
 *
 * An answer is kept in localStorage until the server has it, so neither a lost connection nor a
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

  // The next trial on screen in place of the answered one (nextPlayer in pair.js, nextRater
  // in rating.js): `fresh` replaces `root`, the bar shows `progress` and `answered` of `total`,
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

  // The page's words, in the study's language (app.web.study.wording.script_strings).
  var blob = document.getElementById("i18n");
  var T = blob ? JSON.parse(blob.textContent) : {};
  // A translated string with its %(name)s placeholders filled in (%% is one percent sign).
  function fmt(text, values) {
    return String(text || "").replace(/%\((\w+)\)[sd]|%%/g, function (all, name) {
      return name ? String(values[name]) : "%";
    });
  }

  // For the pages' own scripts (pair.js, rating.js, instructions.js, audio_check.js, done.js).
  window.facepairVotes = { action: voteAction, wait: retryWait, MediaLog: MediaLog, store: store,
                           load: load_, newKey: newKey, post: postAnswer, later: resendLater,
                           requestPlay: requestPlay, buffered: bufferedPercent,
                           playFromStart: playFromStart, ClipSource: ClipSource,
                           endUnplayable: endUnplayable, WEBM: WEBM,
                           showInPlace: showInPlace };
  window.facepairText = { format: fmt, strings: T };

  // A page restored from the back-forward cache would show what was already answered (a pair,
  // a clip, a question of the audio check): fetch it anew.
  window.addEventListener("pageshow", function (e) { if (e.persisted) window.location.reload(); });
})();
