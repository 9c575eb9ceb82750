"""Analysis: compute data first (functions returning numbers and arrays),
plot second (functions taking that data)."""
