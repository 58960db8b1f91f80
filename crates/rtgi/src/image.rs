//! Linear HDR images and their files: EXR (as is) and PNG (exposure, tone map, sRGB).
