"""One seeded fuzz harness over the five readers and the commands built on them (see
`tests.fuzz.harness`)."""
