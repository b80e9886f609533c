"""Reference robots, built only from the subsumption core's public API, the way a user builds theirs."""
