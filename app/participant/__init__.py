"""Participant blueprint: consent, instructions with a practice pair, trials, completion."""
