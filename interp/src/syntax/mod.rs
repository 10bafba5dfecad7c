//! The program's text to runnable code: [`lexer`] (text to tokens), [`parser`] (tokens
//! to a tree), [`compile`] (the tree to flat code, every name and built-in call resolved
//! and checked before anything runs).

pub(crate) mod compile;
pub(crate) mod lexer;
pub(crate) mod parser;
