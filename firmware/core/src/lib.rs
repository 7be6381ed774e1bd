//! HAL-agnostic PuzzleBot robot logic (no_std): encoder, speed estimation, PI loop, motor driver mapping, command session.
