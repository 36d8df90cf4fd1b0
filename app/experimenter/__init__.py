"""Experimenter blueprint: login, studies, jobs, recruitment, monitor, export, reports."""
