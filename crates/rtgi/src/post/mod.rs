//! Post-processes the renderer applies to any technique's radiance, after the technique's passes and
//! before display or readback. They read the frame's G-buffer and the technique's output and write an
//! image of their own, so techniques that accumulate into their output are not disturbed.

pub mod motion_blur;
