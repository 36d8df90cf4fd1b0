"""The study services the blueprints call: studies, enrolment, votes, participants, exports,
privacy, questionnaires, the monitor, recruitment and media logs. They take and return models
and plain values, never a request."""
