"""Worked examples of the core API, small enough to read in one sitting."""
