"""The adaptive prescribed-performance coordinated controller (Lu & Jia 2019, Section 3)."""
