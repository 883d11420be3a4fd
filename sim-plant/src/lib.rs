//! Simulated axis plant: elastic multi-mass axes with a cascade drive controller.
