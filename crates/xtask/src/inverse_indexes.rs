//! The nine motion indexes of paper 003 of any model file (`cargo xtask inverse-indexes MODEL…`),
//! written as `[[target.motion]]` tables: a hidden check's targets made from a model whose truth is
//! known (e.g. a KVLCC2 variant with changed hull derivatives), to run `shipid inverse` on and compare
//! its delivered model's 10/10 zig-zag and 20° turning circle with the variant's own.

use anyhow::{Result, anyhow};
use shipid_inverse::indexes::{INDEX_KEYS, SimSettings, motion_indexes};

pub fn run(models: &[String]) -> Result<()> {
    for spec in models {
        let model =
            shipid_pipeline::model_file::load_model(spec).map_err(|e| anyhow!("{spec}: {e}"))?;
        let q = motion_indexes(model.as_ref(), &SimSettings::default())
            .map_err(|e| anyhow!("{spec}: {e}"))?;
        println!("[[target.motion]]\nname = {:?}", spec);
        for (key, value) in INDEX_KEYS.iter().zip(q.0) {
            println!("{key} = {value}");
        }
        println!();
    }
    Ok(())
}
