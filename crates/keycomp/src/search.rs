//! Querying an index with a mesh (`keycomp query`): the query is analysed under the index's
//! profile, its parts' nearest index parts vote for candidate shapes, and the best-voted
//! candidates are matched part to part and ranked by score (`keycomp_retrieval::rank`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use keycomp_components::DetectParams;
use keycomp_mesh::Mesh;
use keycomp_retrieval::{MatchParams, Ranked, ShapeView, rank_hypotheses};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::collection::Reader;
use crate::options::DetectOptions;
use crate::{Analysed, Error, Profile, Role, analyse_as, analyse_mesh_as, query_profile};

/// A part of the query matched to a part of a result.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PartMatch {
    /// The query's part (index into its description's parts).
    pub query_component: usize,
    /// The result's part (index into its record's parts).
    pub target_component: usize,
    /// Descriptor distance of the pair.
    pub distance: f32,
}

/// One ranked shape.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Hit {
    /// 1 for the best.
    pub rank: usize,
    /// The shape's path as indexed.
    pub path: String,
    /// Score in [0, 1] (`keycomp_retrieval::ShapeMatch::score`).
    pub score: f64,
    /// Geometric verification's fitness (`keycomp_retrieval::ShapeMatch::verified`): the share
    /// of the query's surface sample on the shape's once aligned; `None` when it did not run.
    pub verified: Option<f64>,
    /// The query's scale hypothesis that gave the score (`Analysed::hypothesis`; the matched
    /// query parts are that description's): 0 unless the query is a scale-free fragment.
    pub hypothesis: usize,
    /// Where the query sits on the shape: the similarity transform from the query's file
    /// coordinates to the shape's ([`crate::transform`]); `None` when no alignment was found.
    pub transform: Option<crate::transform::Transform>,
    /// The matched parts.
    pub matches: Vec<PartMatch>,
}

/// Where a query's time went, in milliseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct QueryTimings {
    /// Reading, detecting and describing the query.
    pub describe: f64,
    /// Opening the index.
    pub open: f64,
    /// Candidate search, matching and ranking.
    pub search: f64,
    /// The results' transforms: alignments not found by the ranking, refinements.
    #[serde(default)]
    pub transforms: f64,
    /// All of it.
    pub total: f64,
}

/// A query's answer, as `keycomp query --json` prints it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QueryResult {
    /// The query's name (its path for a file).
    pub query: String,
    /// Parts of the query.
    pub components: usize,
    /// The ranked shapes, best first.
    pub results: Vec<Hit>,
    /// Indexed shapes that were not candidates (none of their parts is among the nearest of a
    /// query part), so not ranked; listed only when the ranking is not cut by `k`.
    pub not_returned: Vec<String>,
    /// Where the time went.
    pub timings_ms: QueryTimings,
}

/// A ranking asks for at least one shape.
fn check_k(k: usize) -> Result<(), Error> {
    if k == 0 {
        return Err(Error::Invalid("k must be at least 1".into()));
    }
    Ok(())
}

/// An index opened for queries, with the profile queries are analysed under.
pub struct Searcher {
    dir: PathBuf,
    reader: Reader,
    profile: Profile,
    open_ms: f64,
    pose_weight: f64,
    verify_weight: Option<f64>,
    refined_results: usize,
}

/// How many of a query's best results get their transform refined on their file's surface by
/// default ([`Searcher::set_refined_results`]).
pub const REFINED_RESULTS: usize = 3;

impl Searcher {
    /// Opens the index at `dir` for queries. The query's profile is always the index's
    /// description (its length unit included), and its detection parameters unless `detect`
    /// asks for others than the default; other parameters than the index's, another
    /// descriptor version or an index without a profile are [`Error::Incomparable`]
    /// ([`query_profile`]).
    pub fn open(dir: &Path, detect: Option<&DetectParams>) -> Result<Searcher, Error> {
        let t = Instant::now();
        let reader = Reader::open_mapped(dir)?;
        let default = DetectOptions::default().retrieval_params();
        let mine = Profile::current(detect.unwrap_or(&default));
        let profile = query_profile(
            dir,
            reader.profile(),
            reader.len(),
            &mine,
            detect.is_none_or(|d| *d == default),
        )?;
        Ok(Searcher {
            dir: dir.to_path_buf(),
            reader,
            profile,
            open_ms: t.elapsed().as_secs_f64() * 1e3,
            pose_weight: 0.0,
            verify_weight: None,
            refined_results: REFINED_RESULTS,
        })
    }

    /// Sets how much geometric verification weighs in the ranking
    /// (`keycomp_retrieval::MatchParams::verify_weight`, in [0, 1]); `None`, the default:
    /// automatic, by whether the query has a boundary (`keycomp_retrieval::verify_weight_for`).
    /// An index written by format 1 to 3 has no surface samples: its shapes are ranked without
    /// verification.
    pub fn set_verify_weight(&mut self, weight: Option<f64>) -> Result<(), Error> {
        self.verify_weight = crate::matching::check_verify_weight(weight)?;
        Ok(())
    }

    /// Sets how much the pose check weighs in the ranking (`keycomp_retrieval::MatchParams::
    /// pose_weight`, in [0, 1]; 0, the default, ranks independently of pose): above 0, shapes
    /// whose matched parts sit as the query's do (the same pose, the exact source of a
    /// fragment) rank above the same parts in another pose. An index written by format 1 or 2
    /// has no part positions: its shapes are ranked without the check.
    pub fn set_pose_weight(&mut self, weight: f64) -> Result<(), Error> {
        self.pose_weight = crate::matching::check_pose_weight(weight)?;
        Ok(())
    }

    /// The index folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The index.
    pub fn reader(&self) -> &Reader {
        &self.reader
    }

    /// The profile queries are analysed under.
    pub fn profile(&self) -> &Profile {
        &self.profile
    }

    /// For an index built by an earlier keycomp, what it keeps doing and how to move it to
    /// this keycomp's analysis ([`Profile::migration_note`]); `None` otherwise.
    pub fn migration_note(&self) -> Option<String> {
        self.profile.migration_note(&self.dir)
    }

    /// Time spent opening the index, in milliseconds.
    pub fn open_ms(&self) -> f64 {
        self.open_ms
    }

    /// Reads and analyses a query file under the index's profile.
    pub fn analyse(&self, path: &Path) -> Result<Analysed, Error> {
        analyse_as(path, &self.profile, Role::Query)
    }

    /// Analyses a query mesh in memory under the index's profile.
    pub fn analyse_mesh(&self, mesh: Mesh) -> Result<Analysed, Error> {
        analyse_mesh_as(mesh, &self.profile, Role::Query)
    }

    /// The `k` best shapes for an analysed query, best first (fewer when fewer shapes are
    /// candidates).
    pub fn rank(&self, query: &Analysed, k: usize) -> Result<Vec<Ranked>, Error> {
        check_k(k)?;
        let params = query.match_params(&MatchParams {
            pose_weight: self.pose_weight,
            verify_weight: query.verify_weight(self.verify_weight),
            ..MatchParams::default()
        });
        // one view per description (a scale-free fragment has one per scale hypothesis)
        let parts: Vec<_> = (0..query.hypothesis_count())
            .map(|h| {
                (
                    query.view_of(h),
                    query.areas_of(h, &params),
                    query.centres_of(h, &params),
                )
            })
            .collect();
        let views: Vec<ShapeView> = parts
            .iter()
            .enumerate()
            .map(|(h, ((descriptors, layout), areas, centres))| ShapeView {
                descriptors,
                layout,
                areas,
                centres,
                sample: query.sample_of(h, &params),
            })
            .collect();
        Ok(rank_hypotheses(&self.reader, &views, k, &params)?)
    }

    /// The serialisable answer for a query named `name` with its ranking `ranked` (from
    /// [`Searcher::rank`] with `k`).
    pub fn result(
        &self,
        name: &str,
        query: &Analysed,
        ranked: &[Ranked],
        k: usize,
        timings_ms: QueryTimings,
    ) -> Result<QueryResult, Error> {
        let not_returned = if ranked.len() < k {
            let seen: std::collections::BTreeSet<_> = ranked.iter().map(|r| r.id).collect();
            self.reader
                .shapes()?
                .iter()
                .filter(|s| !seen.contains(&s.id))
                .map(|s| s.record.path.display().to_string())
                .collect()
        } else {
            Vec::new()
        };
        let transforms = ranked
            .par_iter()
            .enumerate()
            .map(|(i, r)| self.transform_of(query, r, i < self.refined_results))
            .collect::<Result<Vec<_>, Error>>()?;
        Ok(QueryResult {
            query: name.to_string(),
            components: query.description.components.len(),
            results: ranked
                .iter()
                .zip(transforms)
                .enumerate()
                .map(|(i, (r, transform))| Hit {
                    rank: i + 1,
                    path: r.path.display().to_string(),
                    score: r.result.score,
                    verified: r.result.verified,
                    hypothesis: r.hypothesis,
                    transform,
                    matches: r
                        .result
                        .matches
                        .iter()
                        .map(|m| PartMatch {
                            query_component: m.query,
                            target_component: m.target,
                            distance: m.distance,
                        })
                        .collect(),
                })
                .collect(),
            not_returned,
            timings_ms,
        })
    }

    /// Where `query` sits on the ranked shape `r`: the alignment its verification found, or one
    /// found now from the shape's record (a closed query is ranked without verification);
    /// with `refine`, refined on the shape's file.
    fn transform_of(
        &self,
        query: &Analysed,
        r: &Ranked,
        refine: bool,
    ) -> Result<Option<crate::transform::Transform>, Error> {
        let Some(rec) = self.reader.get(r.id)? else {
            return Ok(None);
        };
        let descriptors: Vec<_> = rec.components.iter().map(|c| c.descriptor).collect();
        // no centres (a record of index format 1 or 2): nothing to align with
        let centres: Vec<[f32; 3]> = rec
            .components
            .iter()
            .map(|c| c.centre)
            .collect::<Option<_>>()
            .unwrap_or_default();
        let target = ShapeView {
            descriptors: &descriptors,
            layout: &rec.layout,
            areas: &[],
            centres: &centres,
            sample: &rec.sample,
        };
        let frame = crate::transform::frame_factor(self.profile.describe.units, rec.surface_area);
        let transforms = query.transforms_onto(
            r.hypothesis,
            &r.result,
            target,
            frame,
            &MatchParams::default(),
        );
        if !refine {
            return Ok(transforms.first().copied());
        }
        // refined on the shape's file as it was indexed (unchanged since: same content hash)
        let unchanged = keycomp_index::ContentHash::of_file(&rec.canonical_path)
            .is_ok_and(|h| h == rec.content_hash);
        let file = unchanged
            .then(|| keycomp_mesh::read_mesh(&rec.canonical_path).ok())
            .flatten();
        Ok(match file {
            Some(file) => crate::transform::Transform::refined_best(
                &transforms,
                query.input.positions(),
                &file.mesh,
                query.file_units(),
            ),
            None => transforms.first().copied(),
        })
    }

    /// Sets how many of the best results get their transform refined on their file's surface
    /// ([`crate::transform::Transform::refined_best`]; default [`REFINED_RESULTS`]): each reads
    /// that file again, so a large `k` with all of them refined is slower.
    pub fn set_refined_results(&mut self, n: usize) {
        self.refined_results = n;
    }

    /// Analyses the query file at `path` and ranks the index for it: the `k` best shapes.
    pub fn query(&self, path: &Path, k: usize) -> Result<QueryResult, Error> {
        Ok(self.query_full(path, k)?.2)
    }

    /// [`Searcher::query`], also returning the query's analysis and the ranking itself (for
    /// a report that draws them).
    pub fn query_full(
        &self,
        path: &Path,
        k: usize,
    ) -> Result<(Analysed, Vec<Ranked>, QueryResult), Error> {
        check_k(k)?;
        let t = Instant::now();
        let q = self.analyse(path)?;
        self.answer(&path.display().to_string(), q, k, t)
    }

    /// Analyses the query mesh in memory, named `name`, and ranks the index for it.
    pub fn query_mesh(&self, name: &str, mesh: Mesh, k: usize) -> Result<QueryResult, Error> {
        check_k(k)?;
        let t = Instant::now();
        let q = self.analyse_mesh(mesh)?;
        Ok(self.answer(name, q, k, t)?.2)
    }

    fn answer(
        &self,
        name: &str,
        q: Analysed,
        k: usize,
        t: Instant,
    ) -> Result<(Analysed, Vec<Ranked>, QueryResult), Error> {
        let describe = t.elapsed().as_secs_f64() * 1e3;
        let s = Instant::now();
        let ranked = self.rank(&q, k)?;
        let search = s.elapsed().as_secs_f64() * 1e3;
        let p = Instant::now();
        let mut result = self.result(name, &q, &ranked, k, QueryTimings::default())?;
        result.timings_ms = QueryTimings {
            describe,
            open: self.open_ms,
            search,
            transforms: p.elapsed().as_secs_f64() * 1e3,
            total: self.open_ms + t.elapsed().as_secs_f64() * 1e3,
        };
        Ok((q, ranked, result))
    }
}
