/* facepair audio check (app.web.participant.audio): the question's three sounds play once
 * through, the one playing is marked, and the answers open when they have all been heard. It
 * runs after participant.js (the page's words). */
(function () {
  "use strict";

  var audioCheck = document.querySelector(".audio-player");
  if (!audioCheck) return;
  var T = window.facepairText.strings;
  var sounds = audioCheck.querySelector("audio");
  var playSounds = audioCheck.querySelector(".play-sounds");
  var choices = audioCheck.querySelectorAll(".sound-choice");
  var onsets = JSON.parse(audioCheck.dataset.onsets || "[]");
  var audioHint = audioCheck.querySelector(".hint");
  function mark(playing) {
    for (var c = 0; c < choices.length; c++) choices[c].classList.toggle("playing", c === playing);
  }
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
})();
