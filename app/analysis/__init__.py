"""Analysis of paired-comparison studies: votes -> ballots, tests, agreement, scale, report.

Pure package (no Flask). Entry points: :func:`analyze` (every statistic, JSON-ready),
:func:`app.analysis.report.writer.write_report` (HTML and PDF),
:func:`app.analysis.votes.read_votes` and :func:`app.analysis.votes.write_votes_csv` (the one
votes format).
"""

from app.analysis.results import analyze
from app.analysis.votes import CHOICES, VOTE_COLUMNS, VotesTable, read_votes, write_votes_csv

__all__ = ["CHOICES", "VOTE_COLUMNS", "VotesTable", "analyze", "read_votes", "write_votes_csv"]
