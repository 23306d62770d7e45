//! REM, the remote execution manager (thesis section 4.2.4.1).
