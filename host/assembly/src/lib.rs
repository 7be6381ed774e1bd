//! Assembly shapes, connection-pair task assignment and pair status machines (THESIS Algorithms 1-8).
