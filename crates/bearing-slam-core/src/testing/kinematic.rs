//! A kinematic (no physics) scenario generator for end-to-end tests, until
//! the physics simulator is used.
