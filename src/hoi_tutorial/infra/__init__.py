"""Infrastructure every chapter shares: scale presets, seeding, device choice, the artifact
cache, a model-agnostic training loop, progress bars (also from worker processes) and paper-vs-ours tables."""
from .cache import (
    CacheStoreWarning,
    CorruptArtifactWarning,
    NotCachedError,
    artifact_key,
    artifact_path,
    cache_dir,
    cache_only,
    clear_cache,
    load_or_build,
    prune_cache,
    state_dict_to_cpu,
)
from .device import choose_device, one_thread, single_threaded, threads_allowed
from .pack import PackMismatchError, make_pack, read_manifest, release_pack_url, unpack, use_pretrained
from .parallel import available_cores, in_order, warm_cache
from .progress import progress_enabled, show_progress
from .presets import SCALES, by_scale, check_scale, scaled_config
from .seeding import check_seed, rng, seed_everything
from .cleaned_source import source_digest
from .tables import format_seconds, side_by_side
from .training import (TrainedModel, TrainerConfig, TrainResult, learning_rate_factor, move_to_device, train,
                       trainer_config)

__all__ = [
    "SCALES", "by_scale", "check_scale", "scaled_config",
    "check_seed", "rng", "seed_everything",
    "choose_device", "one_thread", "single_threaded", "threads_allowed", "available_cores", "in_order", "warm_cache",
    "CacheStoreWarning", "CorruptArtifactWarning", "NotCachedError", "cache_only", "artifact_key", "artifact_path",
    "cache_dir", "clear_cache", "prune_cache", "load_or_build", "state_dict_to_cpu", "source_digest",
    "TrainerConfig", "TrainResult", "TrainedModel", "trainer_config", "learning_rate_factor", "move_to_device", "train",
    "format_seconds", "side_by_side", "show_progress", "progress_enabled",
    "PackMismatchError", "make_pack", "read_manifest", "release_pack_url", "unpack", "use_pretrained",
]
