"""The shipped scenes and layouts: this directory's *.yaml files, installed as the package
``ungrasp_ompl.shipped_scenes`` (see setup.py). Use them by name (``ungrasp-ompl plan
guitar_pick``, ``ungrasp-ompl scenes`` lists them); ``ungrasp_ompl.shipped`` resolves the names."""
