"""The run pipeline: a typed request, the stages every run goes through, the backend table.

The CLI (``fmionnx run``), the Python API (:func:`fmionnx.run`, ``System.run``) and studies
build a :class:`~fmionnx.pipeline.request.RunRequest` and hand it to
:func:`~fmionnx.pipeline.run.execute`; none of them orchestrates a run itself. Modules:

- :mod:`.request` — the request and :func:`~.request.build_request`, which checks it once;
- :mod:`.backends` — the backend table (``--backend``);
- :mod:`.system` — loading and compiling (``fmionnx.load``);
- :mod:`.run` — the stages, :func:`~.run.execute` and :func:`~.run.run`;
- :mod:`.observers` — the typed hooks progress bars and live views attach to;
- :mod:`.outcome`, :mod:`.errors`, :mod:`.outputs`, :mod:`.infer`.

Nothing is imported here: ``import fmionnx.pipeline.errors`` stays as light as the CLI's
start-up needs.
"""
