//! Texture layers: a texture placed in the shell with its `(s, t)` offset (thick
//! surfaces, chapter 7, editing: move, combine). The bake and both renderers take the
//! layers a shell carries and unite them.

use super::VolumeTexture;
use glam::Vec2;

/// A texture placed in the shell: `(s, t)` offset (editing: move, combine).
#[derive(Debug, Clone)]
pub struct TextureLayer {
    pub texture: VolumeTexture,
    pub offset: Vec2,
}
