//! The sensor model inside the simulator: lost frames in the backend, the accelerometer at its
//! drawn position, everything off reproducing the truth.
