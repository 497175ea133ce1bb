"""The sweep backend: a study's cases on a Dask cluster (local by default, or an existing one).

:mod:`.engine` starts or joins the cluster, sends the cases as tasks and collects outcomes;
:mod:`.batching` decides how many short cases one task runs; :mod:`.case` runs a task's cases
on a worker with the in-process backend; :mod:`.models` ships model files by content hash.
"""
