//! Software-in-the-loop simulator: motor/body/coupling plant running firmware/core over loopback UDP.
