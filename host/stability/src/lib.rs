//! Quasi-static stability of modular assemblies as a second-order cone program (the stability gate).
