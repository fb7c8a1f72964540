"""Reports over many checkpoints: the paper's Table 1 layout, its figures and the JSON behind them."""

from ftin.report.table import (
    PAPER_COLUMNS,
    DatasetSpec,
    PaperTable,
    ReportError,
    ReportFiles,
    ReportResults,
    evaluate_checkpoints,
    find_checkpoints,
    load_checkpoints,
    load_datasets,
    paper_table,
    parse_dataset_options,
    write_report,
)

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
    "parse_dataset_options",
    "write_report",
]
