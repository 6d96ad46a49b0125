"""`python -m contact_bench`: the same as the `contact-bench` command."""

import sys

from contact_bench.cli.entry import main

sys.exit(main())
