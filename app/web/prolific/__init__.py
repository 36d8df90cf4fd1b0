"""Recruiting on Prolific without hand work: one client for Prolific's API v1, an outbox that
sends every change at most once, the submissions' outcomes (webhook and polling), review,
bonuses and top-ups (``docs/reference/prolific.md``).

Services only (no request objects), like ``app.web.study``: the experimenter's pages
(``app.web.experimenter.prolific``), the webhook (``app.web.api.prolific``) and the CLI
(``app.commands.prolific``) call them.

- ``models``: the rows (the Prolific study, the outbox, submissions, webhook events);
- ``client``: the HTTP client (token, retries, paging, timeouts, one-line errors);
- ``outbox``: record, claim, send, reconcile; ``calls``: what each kind of call sends and how
  its effect is read back from Prolific;
- ``outcomes``: submission statuses from webhooks and polling; a RETURNED or TIMED-OUT
  submission makes the participant ``returned``;
- ``recruit``: publishing, the cost, top-ups; ``review``: approve, reject, request return;
  ``bonus``: bonus batches.
"""
