"""Sub-commands of the ``nightloc`` command line (see :mod:`nightloc.cli`)."""
