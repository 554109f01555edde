//! The study figures' files: unique names, no leftovers of earlier runs, no case left out silently.

mod study_figures;
