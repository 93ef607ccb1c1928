"""What recorder and replay share: the log contract, the field, errors, CLI plumbing."""
