//! (msh: to be written)
