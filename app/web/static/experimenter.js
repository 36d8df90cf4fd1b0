/* facepair experimenter pages: live progress of background jobs. */
(function () {
  "use strict";
  var jobs = document.querySelectorAll(".job[data-job-url]");

  function poll(item) {
    var status = item.dataset.status;
    if (status !== "queued" && status !== "running") return;
    fetch(item.dataset.jobUrl, { headers: { Accept: "application/json" }, cache: "no-store" })
      .then(function (r) { return r.json(); })
      .then(function (job) {
        item.querySelector("progress").value = job.fraction;
        item.querySelector(".job-status").textContent =
          job.status + (job.total ? " " + job.done + "/" + job.total : "");
        item.querySelector(".job-message").textContent = job.message;
        item.className = "job job-" + job.status;
        item.dataset.status = job.status;
        if (job.status === "done" || job.status === "failed") {
          // Counts of rendered clips and the buttons depend on the finished job.
          window.setTimeout(function () { window.location.reload(); }, 800);
        } else {
          window.setTimeout(function () { poll(item); }, 1000);
        }
      })
      .catch(function () { window.setTimeout(function () { poll(item); }, 5000); });
  }

  Array.prototype.forEach.call(jobs, poll);
})();
