//! The PuzzleBot host daemon library and the `puzzlebot` binary.
