//! Rebuilds the crate when a migration file changes: `sqlx::migrate!`
//! embeds the top-level `migrations/` at compile time but does not tell cargo to watch
//! it, so an edited `.sql` file would otherwise leave the old migration in
//! the binary (the sqlx documentation recommends this script).
fn main() {
    println!("cargo:rerun-if-changed=../../migrations");
}
