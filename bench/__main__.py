"""`python -m contact_bench`: the same as the `contact-bench` command."""

import sys

from contact_bench.cli.main import main

sys.exit(main())
