"""The paper's comparisons and studies (``endoloc experiment``), each writing one output folder
with its tables, plots and an HTML report. Keyword arguments are the command's options; the
data are ``data`` (dataset folder), ``train`` and ``test`` (sequence names)."""

from __future__ import annotations

from ._jobs import job

__all__ = ["benchmark", "changes", "compare", "expert", "perturb", "zones"]


def benchmark(*, progress=None, **options):
    """The whole chain over several colons; each method's mean ± 95 % interval across them."""
    return job("experiment.benchmark", progress, options)


def changes(*, progress=None, **options):
    """Each factor of a colon that changes between the passes, alone at each severity, over
    several colons: where endoloc stops holding."""
    return job("experiment.changes", progress, options)


def compare(*, progress=None, **options):
    """Every method on one dataset against the baselines, as the paper's Table I."""
    return job("experiment.compare", progress, options)


def zones(*, progress=None, **options):
    """Monte-Carlo sweep of the zone count (the paper's Fig. 4); ``--from`` is ``from_``."""
    return job("experiment.zones", progress, options)


def expert(*, progress=None, **options):
    """Anatomical zones against the best uniform zone count."""
    return job("experiment.expert", progress, options)


def perturb(*, progress=None, **options):
    """The zone forced k ± e away, errors against e (the paper's Fig. 7)."""
    return job("experiment.perturb", progress, options)
