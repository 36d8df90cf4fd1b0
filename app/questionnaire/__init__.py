"""Questionnaire blueprint: the pages of questions before and after a participant's trials."""
