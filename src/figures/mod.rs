//! What a reader looks at: the pictures (`plots`), the self-contained 3-D page (`view`) and the
//! pictures of a batch (`report`).

pub mod plots;
pub mod report;
pub mod view;
