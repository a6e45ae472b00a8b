"""``python -m scripts.results [--check]``."""

from scripts.results import main

raise SystemExit(main())
