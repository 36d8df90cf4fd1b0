"""The report of an analysis: its blocks, its sections, its figures, and its HTML and PDF.

The statistics stay in :mod:`app.analysis`; this package only says what they found. Its modules
import one way, each only those listed before it:

- :mod:`~app.analysis.report.blocks`: heading, paragraph, table and plot, and the way their
  text prints numbers;
- :mod:`~app.analysis.report.figures`: the matplotlib figures;
- :mod:`~app.analysis.report.mixed_document`, :mod:`~app.analysis.report.inference_document`,
  :mod:`~app.analysis.report.answer_document`, :mod:`~app.analysis.report.rating_document` and
  :mod:`~app.analysis.report.study_document`: the sections, each a list of blocks;
- :mod:`~app.analysis.report.results_text`: a paired-comparison study's results in words;
- :mod:`~app.analysis.report.document`: :func:`~app.analysis.report.document.build_document`,
  every block of a report in reading order;
- :mod:`~app.analysis.report.writer`: :func:`~app.analysis.report.writer.write_report`, the
  blocks as one self-contained HTML file and a PDF.

Nothing is imported here, so importing one module (``facepair plan`` draws a figure) loads no
other and analysing votes never loads matplotlib.
"""
