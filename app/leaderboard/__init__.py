"""The talking-face leaderboard's pure logic: season files and their manifest, submission checks,
round plans, scores, rank bands and the published document (no Flask, no database).

A *season* is a benchmark set of speech segments with transcripts and captured ground truth,
one frozen render setting and frozen test settings (:mod:`app.leaderboard.season`). Submitters
send one track per segment (:mod:`app.leaderboard.checks`); *rounds* compare the queued
systems with anchors in a paired study whose pairs are planned by expected information gain
(:mod:`app.leaderboard.pairing`); the votes of every round are fitted together
(:mod:`app.leaderboard.scores`) and published as ``leaderboard.json``
(:mod:`app.leaderboard.board`). The web layer (``app/web/board``) keeps the rows and runs the
studies; this package only computes.
"""
