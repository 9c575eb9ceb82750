"""Control design and its studies: QFT (bounds, loop shaping, verification,
delay margins, the plant family from linearised diagrams), step and
anti-windup studies of the CPFL loop, and the zero dynamics."""
