"""Reports over many checkpoints: the paper's Table 1 layout, its figures and the JSON behind them.

``results`` (layout and result types) <- ``evaluation`` (checkpoints on datasets, through
``ftin.evaluate``'s inference path) <- ``render`` (Markdown, CSV, JSON, via ``figures``);
``campaign`` tables the training campaign's collected results. Arrows point one way: no cycle.
"""

from ftin.report.evaluation import evaluate_checkpoints, find_checkpoints, load_checkpoints, load_datasets
from ftin.report.render import PaperTable, ReportFiles, paper_table, write_report
from ftin.report.results import PAPER_COLUMNS, DatasetSpec, ReportError, ReportResults

__all__ = [
    "PAPER_COLUMNS",
    "DatasetSpec",
    "PaperTable",
    "ReportError",
    "ReportFiles",
    "ReportResults",
    "evaluate_checkpoints",
    "find_checkpoints",
    "load_checkpoints",
    "load_datasets",
    "paper_table",
    "write_report",
]
