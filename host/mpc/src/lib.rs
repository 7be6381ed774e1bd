//! Distributed model predictive control of PuzzleBots (Clarabel, real-time iteration).
