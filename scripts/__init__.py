"""The ``topomap`` command line and the scripts behind its experiments, tables and report."""
