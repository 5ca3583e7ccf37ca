"""What the commands' output options accept (checked before any work starts)."""

__all__ = ["PLOT_EXTENSIONS", "JSON_EXTENSIONS", "CSV_EXTENSIONS"]

#: Plot files: the formats :func:`bodyvib.plotting.save_figure` writes.
PLOT_EXTENSIONS = (".png", ".pdf", ".svg")
#: JSON documents (figures, parameter files).
JSON_EXTENSIONS = (".json",)
#: Time histories.
CSV_EXTENSIONS = (".csv",)
