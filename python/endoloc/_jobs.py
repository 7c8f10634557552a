"""How the job functions call the extension: progress sinks and the job runner."""

from __future__ import annotations

from . import _endoloc


def progress_callback(progress):
    """The callable the extension calls, from ``progress=`` (None, False, True or a callable)."""
    if progress is None or progress is False:
        return None
    if progress is True:
        from .progress import default_progress

        return default_progress()
    if callable(progress):
        return progress
    raise TypeError(
        f"progress: expected None, True or a callable (event, text, done, total), got {type(progress).__name__}"
    )


def job(name: str, progress, options: dict):
    """Run job ``name`` (e.g. ``"train"``, ``"experiment.compare"``) with its options."""
    return _endoloc.run_job(name, progress_callback(progress), **options)


def options(name: str) -> list[str]:
    """The keyword arguments job ``name`` takes (its command-line options, ``-`` as ``_``)."""
    return _endoloc.job_options(name)
