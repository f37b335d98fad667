"""Model hyper-parameters shared by NavAff, its ablations and the baselines."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from momakitchen import codec
from momakitchen.errors import MomaError
from momakitchen.robots.spec import DESCRIPTOR_LAYOUTS, DESCRIPTOR_VERSION, descriptor_dim


@dataclass(frozen=True)
class ModelConfig:
    """Sizes of a model (reference values: docs/DESIGN.md §3.6).

    Attributes:
        embed_dim: token width of the cross-attention (paper: 512).
        num_tokens: global and floor tokens (centroids of the last set abstraction; 64).
        num_heads: attention heads (4).
        dropout: attention and feed-forward dropout (0.1).
        num_robot_tokens: tokens the robot descriptor is expanded into.
        attention_layers: stacked cross-attention blocks.
        width: multiplier of the PointNet++ MLP widths (1.0 = reference widths).
        global_npoints: centroids of the first two global set abstractions (the third
            yields ``num_tokens``).
        floor_npoints: centroids of the first floor set abstraction (the second yields
            ``num_tokens``).
        nsample_scale: multiplier of the neighbour counts (16, 32, 64 per scale).
        pos_freqs: sine/cosine frequencies of the point-position encoding (0: raw xyz).
        lambda_zero: weighted-MSE weight on zero-valued labels (0.7).
        zero_weight_prob: probability that a training step applies ``lambda_zero`` (0.5).
        kl_weight: weight of a KL-divergence term between the normalised label and
            predicted maps added to the loss (0: the paper's weighted MSE alone).
        peak_weight: weight of a listwise ranking term (the KL divergence of the
            softmax of the labels from that of the prediction, temperature
            ``peak_temperature``) that rewards ranking the map's best points first
            (0: none).
        peak_temperature: its temperature, in label units (0.1).
        target_points: NavAff only: target points (farthest-point sampled from the
            global points flagged as target) that every first-level floor centroid
            encodes in its own frame, a PointNet over the target's shape as seen from
            there (e.g. where a door's hinge is relative to its handle); 0: none (every
            preset: it did not help in a pilot, docs/RESULTS.md).
        robot_head: NavAff only: also condition the per-point head on the robot
            descriptor, as the baselines' head is, so that every floor point sees the
            robot directly and not only through the attended floor tokens (False: the
            paper's NavAff, and every preset: it did not help in a pilot,
            docs/RESULTS.md).
        relative_dropout: NavAff only: probability, per training episode, that the
            floor's target-relative encoding (offset and distance to the target) is
            zeroed, so that the model must find the target in the global cloud. Without
            it, full-length runs can settle on a shortcut (floor position, target offset
            and robot alone) and leave the global cloud unused (docs/RESULTS.md); 0: none
            (the ``cpu`` preset: 0.5).
        reach_input: NavAff only: every floor point also reads the robot's reachability
            of the target from there (:mod:`momakitchen.models.reach_input`, from the
            robot's URDF and mount), so that a robot is known by what its arm reaches and
            not only by its descriptor's numbers (False: runs made before it).
        reach_points: with ``reach_input``, ``reach_gate`` or ``index_gate``: at how many
            of the target's points the reachability is read, each channel the best over
            them. 1: at the target's centroid (runs made before this field); K > 1: at K
            of its visible points, spread over it
            (:func:`~momakitchen.models.reach_input.target_points`), since a door is opened
            at its handle, not at its centre.
        reach_gate: any model: each prediction is multiplied by ``sigmoid(d / reach_gate)``,
            ``d`` (m) how far inside the robot's reachable region the target lies from
            that floor point (:func:`~momakitchen.models.reach_input.reach_gate`, at
            ``reach_points`` of its points), so that no stance the arm cannot reach from
            is chosen, whatever the network learnt; 0: no gate.
        index_gate: any model: each prediction is also multiplied by
            ``min(1, r / index_gate)``, ``r`` the reachability index of the target from
            that floor point (the share of approach directions by which the arm reaches
            it, at ``reach_points`` of its points; the weight at least 0.01), so that a
            stance at the edge of the arm's reach, where the target's unseen depth or the
            grasp's orientation loses it, counts less than one well inside, and stances
            reached from at least ``index_gate`` of the directions count alike
            (docs/RESULTS.md); 1: the plain index; 0: no gate.
        index_picks_only: with ``index_gate``: weigh only the targets the robot picks,
            not those it opens (a door's or a drawer's handle, the batch's
            ``target_opens``): the index says where the arm reaches the handle, not
            along the path it must pull it, and an opening stood nearer by the weight
            collides with its own door (docs/RESULTS.md). A batch that does not say
            which targets open is weighed whole; False: every target is weighed.
        footprint_gate: any model: each prediction is multiplied by 0 where the robot's
            base, facing the target, would stand on points the view shows above the floor
            (:func:`~momakitchen.models.reach_input.footprint_gate`, the test the
            classical methods place by); False: no gate.
        hidden_descriptor: names of robot descriptor columns the model does not read
            (zeroed before it sees them), e.g. the reach and mount numbers of a model
            that knows the arm by its reachability (``reach_input``); (): it reads all.
        descriptor_version: the robot descriptor layout the model reads
            (``momakitchen.robots.spec.DESCRIPTOR_LAYOUTS``): of a newer descriptor it
            takes the first columns. Recorded as the checkpoint's ``descriptor_version``
            (runs made before this field read version 1).
    """

    embed_dim: int = 512
    num_tokens: int = 64
    num_heads: int = 4
    dropout: float = 0.1
    num_robot_tokens: int = 4
    attention_layers: int = 1
    width: float = 1.0
    global_npoints: tuple[int, int] = (1024, 256)
    floor_npoints: int = 256
    nsample_scale: float = 1.0
    pos_freqs: int = 4
    lambda_zero: float = 0.7
    zero_weight_prob: float = 0.5
    kl_weight: float = 0.0
    peak_weight: float = 0.0
    peak_temperature: float = 0.1
    target_points: int = 0
    robot_head: bool = False
    relative_dropout: float = 0.0
    descriptor_version: int = DESCRIPTOR_VERSION
    reach_input: bool = field(default=False, metadata=codec.OMIT_IF_DEFAULT)
    reach_points: int = field(default=1, metadata=codec.OMIT_IF_DEFAULT)
    reach_gate: float = field(default=0.0, metadata=codec.OMIT_IF_DEFAULT)
    index_gate: float = field(default=0.0, metadata=codec.OMIT_IF_DEFAULT)
    index_picks_only: bool = field(default=False, metadata=codec.OMIT_IF_DEFAULT)
    footprint_gate: bool = field(default=False, metadata=codec.OMIT_IF_DEFAULT)
    hidden_descriptor: tuple[str, ...] = field(default=(), metadata=codec.OMIT_IF_DEFAULT)

    def __post_init__(self) -> None:
        def bad(name: str, rule: str) -> MomaError:
            return MomaError(f"ModelConfig.{name} {rule}, got {getattr(self, name)!r}")

        if self.embed_dim < 8:
            raise bad("embed_dim", "must be >= 8")
        if self.num_heads < 1 or self.embed_dim % self.num_heads:
            raise bad("num_heads", f"must be >= 1 and divide embed_dim={self.embed_dim}")
        if self.num_tokens < 1:
            raise bad("num_tokens", "must be >= 1")
        if not 0.0 <= self.dropout < 1.0:
            raise bad("dropout", "must be in [0, 1)")
        if self.num_robot_tokens < 1:
            raise bad("num_robot_tokens", "must be >= 1")
        if self.attention_layers < 1:
            raise bad("attention_layers", "must be >= 1")
        if not 0.05 <= self.width <= 8.0:
            raise bad("width", "must be in [0.05, 8]")
        g = tuple(self.global_npoints)
        if len(g) != 2 or not g[0] >= g[1] >= self.num_tokens:
            rule = f"must be two counts n1 >= n2 >= num_tokens={self.num_tokens}"
            raise bad("global_npoints", rule)
        object.__setattr__(self, "global_npoints", (int(g[0]), int(g[1])))
        if self.floor_npoints < self.num_tokens:
            raise bad("floor_npoints", f"must be >= num_tokens={self.num_tokens}")
        if not 0.05 <= self.nsample_scale <= 4.0:
            raise bad("nsample_scale", "must be in [0.05, 4]")
        if not 0 <= self.pos_freqs <= 12:
            raise bad("pos_freqs", "must be in [0, 12]")
        if self.lambda_zero < 0:
            raise bad("lambda_zero", "must be >= 0")
        if not 0.0 <= self.zero_weight_prob <= 1.0:
            raise bad("zero_weight_prob", "must be in [0, 1]")
        if not 0.0 <= self.kl_weight <= 10.0:
            raise bad("kl_weight", "must be in [0, 10]")
        if not 0.0 <= self.peak_weight <= 10.0:
            raise bad("peak_weight", "must be in [0, 10]")
        if not 0.01 <= self.peak_temperature <= 10.0:
            raise bad("peak_temperature", "must be in [0.01, 10]")
        if not 0 <= self.target_points <= 1024:
            raise bad("target_points", "must be in [0, 1024]")
        if not isinstance(self.robot_head, bool):
            raise bad("robot_head", "must be true or false")
        if not 0.0 <= self.relative_dropout < 1.0:
            raise bad("relative_dropout", "must be in [0, 1)")
        if not isinstance(self.reach_input, bool):
            raise bad("reach_input", "must be true or false")
        if isinstance(self.reach_points, bool) or self.reach_points not in range(1, 65):
            raise bad("reach_points", "must be an integer in [1, 64]")
        if not 0.0 <= self.reach_gate <= 1.0:
            raise bad("reach_gate", "must be in [0, 1] m (0: no gate)")
        if isinstance(self.index_gate, bool) or not 0.0 <= self.index_gate <= 1.0:
            raise bad("index_gate", "must be in [0, 1] (0: no gate)")
        if not isinstance(self.index_picks_only, bool):
            raise bad("index_picks_only", "must be true or false")
        if self.index_picks_only and not self.index_gate:
            raise bad("index_picks_only", "needs index_gate > 0 (it says which targets it weighs)")
        if not isinstance(self.footprint_gate, bool):
            raise bad("footprint_gate", "must be true or false")
        names = DESCRIPTOR_LAYOUTS.get(self.descriptor_version, ())
        hidden = tuple(self.hidden_descriptor)
        if any(h not in names for h in hidden) or len(set(hidden)) != len(hidden):
            raise bad("hidden_descriptor", f"must name distinct columns of {names}")
        object.__setattr__(self, "hidden_descriptor", hidden)
        if self.descriptor_version not in DESCRIPTOR_LAYOUTS:
            raise bad("descriptor_version", f"must be one of {sorted(DESCRIPTOR_LAYOUTS)}")

    @property
    def descriptor_keep(self) -> tuple[float, ...]:
        """Per descriptor column the model reads: 1.0, or 0.0 where it is hidden."""
        names = DESCRIPTOR_LAYOUTS[self.descriptor_version]
        return tuple(0.0 if n in self.hidden_descriptor else 1.0 for n in names)

    @property
    def descriptor_dim(self) -> int:
        """How many descriptor columns the model reads."""
        return descriptor_dim(self.descriptor_version)

    def ch(self, channels: int) -> int:
        """A reference MLP width scaled by ``width`` (at least 8)."""
        return max(8, round(channels * self.width))

    def ns(self, nsample: int) -> int:
        """A reference neighbour count scaled by ``nsample_scale`` (at least 4)."""
        return max(4, round(nsample * self.nsample_scale))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields (see :func:`momakitchen.codec.to_dict`)."""
        return codec.to_dict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, where: str = "model_config") -> ModelConfig:
        """Inverse of :meth:`to_dict`; missing keys take the defaults (see
        :func:`momakitchen.codec.from_dict`)."""
        return codec.from_dict(cls, data, where=where)


# A model small enough to run every architecture in well under a second and to train in
# seconds on one core (tests, smoke runs; not for results).
TINY_MODEL = ModelConfig(
    embed_dim=32,
    num_tokens=8,
    num_heads=4,
    num_robot_tokens=2,
    width=0.125,
    global_npoints=(64, 32),
    floor_npoints=32,
    nsample_scale=0.25,
)
