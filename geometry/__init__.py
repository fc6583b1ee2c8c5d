"""Pure geometry shared by the agents and the world, with no I/O: small-vector arithmetic
(vectors.py), the leader's path as a function of time (path.py), and the safety filter, the
velocity nearest the nominal inside a polytope of half-spaces (safety.py). It knows the wire's
types (shoal.bus) and nothing else of shoal."""
