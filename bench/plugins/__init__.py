"""The namespace of plugin files loaded from plugin folders (``--plugins DIR`` and
`CONTACT_BENCH_PLUGINS`): the file ``DIR/name.py`` becomes ``contact_bench.plugins.name``
(see `contact_bench.api.registry`). Empty in the repository."""
