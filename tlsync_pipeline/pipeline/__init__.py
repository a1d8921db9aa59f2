"""The engine: project file, Workspace (the work folder), stage specs (one module per stage under
``stages``), graph, engine, cache, executors, lock."""
