"""graspjax's version."""

# The one place the version is set (pyproject.toml reads it). The minor number goes up with
# every change to what a row of attempts.csv or rounds.csv means (a column, a reason, the
# scenes, the method's reading); every result's config.json also names its code exactly
# (`provenance.code_identity`).
__version__ = "0.2.0"
