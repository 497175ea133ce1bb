"""Isolation: components whose models run in a child process of their own (``--isolate``).

A supplier's FMU is native code: a segfault, ``abort()``, ``exit()`` or endless loop in it
would otherwise end or hang the whole run and lose its results. An isolated component runs
its ordinary runner in a child (:mod:`.child`) behind a proxy runner (:mod:`.proxy`) that
exchanges port values through shared memory (:mod:`.channel`), so the master and the results
survive whatever the model does. ``docs/security.md`` says when to use it and what it costs.
"""
