//! Writing a scene as glTF 2.0 binary (.glb).
