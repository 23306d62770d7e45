//! modeler: the command-line successor of the thesis's "Scene" editor (section 2.4).
