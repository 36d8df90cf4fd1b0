"""Who sees what, in which order and on which side: pair designs, schedules, assignment, rules.

Pure (no Flask). The web layer uses it as:

- :mod:`app.trials.studyfile` ``load_study_file(path) -> StudySpec`` (TOML study files);
- :mod:`app.trials.design` ``build_pairs(conditions, design, reference=...)`` and
  ``stimulus_pairs`` (the side-by-side clips to render);
- :mod:`app.trials.schedule` ``participant_seed``, ``n_lists_for``, ``make_schedule`` (a list
  of :class:`app.trials.trial.ScheduledTrial`); :mod:`app.trials.stimuli` ``shown_stimuli``
  and ``variant_stimuli`` (every clip some schedule can show);
- :mod:`app.trials.assignment` ``choose_list(counts, rng)`` over the assignment table;
- :mod:`app.trials.rules` ``ReplayPolicy``, ``may_play``, ``may_vote``, ``CHOICES``.
"""
