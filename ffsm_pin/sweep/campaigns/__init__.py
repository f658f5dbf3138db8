"""The built-in campaign files (``python -m ffsm_pin.sweep NAME``; docs/campaigns.md)."""
