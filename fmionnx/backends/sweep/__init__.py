"""The sweep backend: a study's cases on a Dask cluster (local by default, or an existing one).

:mod:`.engine` starts or joins the cluster and collects outcomes; :mod:`.case` runs one case
on a worker with the in-process backend; :mod:`.models` ships model files by content hash.
"""
