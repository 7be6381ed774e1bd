//! End-to-end tests: the host against a simulated fleet over loopback sockets.
