"""The registry of diagnostic codes: one title and one explanation each.

`rmv explain CODE` prints the explanation; docs/diagnostics.md is generated from
this table (tests keep the two in step). Codes are stable: never reuse a number.
Ranges: RMV0xx files and imports, RMV1xx syntax, RMV2xx names and structure,
RMV3xx types, RMV5xx analyses.
"""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from dataclasses import dataclass


def _function_list() -> str:
    """RMV215's list of functions, from the registry (read when first explained:
    every command checks codes, few explain them)."""
    from rmvdsl.lang import builtins

    groups = [("aggregations", "aggregation"), ("selectors", "selector"),
              ("transformations", "transformation")]  # fmt: skip
    parts = []
    for title, group in groups:
        names = sorted(n for n, f in builtins.FUNCTIONS.items() if f.group == group)
        parts.append(f"{title} ({', '.join(names)})")
    text = ", ".join(parts[:-1]) + " and " + parts[-1] + "."
    return textwrap.fill(text, 80)


@dataclass(frozen=True)
class Code:
    code: str
    title: str
    text: str  # the explanation, but for what `_ADDED` works out when it is read

    @property
    def explanation(self) -> str:
        added = _ADDED.get(self.code)
        return self.text if added is None else self.text + added()


_TABLE: list[tuple[str, str, str]] = [
    (
        "RMV001",
        "imported file not found",
        """An `import "path.rmv"` names a file that does not exist. Paths are relative to
the folder of the file that imports them.

    import "common/topics.rmv"   // looked up next to this file

Fix the path, or create the file.""",
    ),
    (
        "RMV002",
        "import cycle",
        """A file imports itself, directly or through other files. Each file is read
once; the cycle is reported at the import that closes it. Move the shared
declarations into a third file that both import.""",
    ),
    (
        "RMV003",
        "imported file unreadable",
        """An imported file exists but cannot be read, or is not UTF-8 text, or is not a
`.rmv` file at all (such a file is never read: its lines would end up in the
diagnostics). Save specs as UTF-8 `.rmv` files and check their permissions.""",
    ),
    (
        "RMV100",
        "syntax error",
        """The parser met a token it did not expect here. The message lists what would
have been accepted. The parser recovers at the next declaration (a line that
starts with `topic`, `var`, `event`, `alert`, `transducer`, `property`,
`whitelist`, `node`, ...), so every broken declaration in a file is reported.

    var Speed = status.velocity +   // error: expected a field name ...""",
    ),
    (
        "RMV101",
        "unexpected character",
        """A character that cannot start any token of the language, for example `$` or
`@`. Strings are written in double quotes; comments start with `//`. A run of such
characters (`$$$`, 500 NUL bytes) is one error. Names are ASCII letters, digits and
`_`: a name in another script (`Скорость`) is one error that says so; a ROS field
keeps its own spelling in the topic's message, only the spec's names are ASCII.""",
    ),
    (
        "RMV102",
        "unterminated string",
        """A string literal has no closing double quote on its line. Strings cannot span
lines; inside a string, write `\\"` for a quote and `\\\\` for a backslash.
Other backslashes are kept as they are, so LaTeX formulas such as
"\\until_{<10}" need no escaping.""",
    ),
    (
        "RMV103",
        "unexpected end of file",
        """The file ends inside a declaration, most often because a `}` or `)` is
missing. The label points at the opening that is still open.""",
    ),
    (
        "RMV104",
        "syntax error in a LaTeX formula",
        """The LaTeX form of an RMTLD3 property (`property P: latex "..."`) does not
parse. The notation is rmtld3synth's: `\\lor`, `\\land`, `\\neg`, `\\rightarrow`,
`\\until_{<10}` (or `\\until{<10}` as printed in the thesis), `\\since_{<10}`,
`\\eventually_{<10}`, `\\always_{=5}`, `\\int^{10} p`, terms with `+` and `*`,
and `<`, `<=`, `>`, `>=`, `=` between terms.""",
    ),
    (
        "RMV105",
        "unknown unit",
        """A number carries a unit the language does not know. Time units are `ns`,
`us`, `ms`, `s`, `m` (minutes), `h`, `d`, `w`; rates are written in `Hz`.

    event Fast = mean(Velocity) group by time(100ms)   // ok
    event Slow = mean(Velocity) group by time(100sec)  // error: unknown unit""",
    ),
    (
        "RMV106",
        "number out of range",
        """A number has more digits, or a larger or smaller magnitude, than rmvdsl reads:
at most 100 digits, and a magnitude below 10^300 (zero, or at least 10^-300). Such a
number cannot be a field value, a bound or a time of a real system, and reading
`1e99999999` exactly would take unbounded time and memory. The same range holds for
trace times and for times given on the command line.

    event Fast when Velocity > 1e999   // RMV106: use a number a double can hold""",
    ),
    (
        "RMV200",
        "undefined name",
        """A name is used but never declared (in this file or the files it imports).
Names are case-sensitive; the help line suggests the closest declared name.""",
    ),
    (
        "RMV201",
        "duplicate declaration",
        """Two declarations share one name. Topics, variables, events, alerts,
transducers, states and properties share one namespace, so a state cannot be
named like an event. The secondary label shows the first declaration.""",
    ),
    (
        "RMV202",
        "wrong kind of name",
        """A declared name is used where another kind is required: a variable path must
start with a topic; event expressions use variables and events; transitions take
a boolean event as input; properties are made of transducer states and boolean
events; a whitelist names a topic.""",
    ),
    (
        "RMV203",
        "unused declaration",
        """(warning) A topic that no variable or whitelist uses, a variable that no event
or alert reads, or an event that nothing reads. Remove it, or use it. With
`--strict`, warnings fail the check.""",
    ),
    (
        "RMV204",
        "invalid ROS topic name",
        """A topic name breaks the ROS naming rules: names are made of tokens of
letters, digits and underscores separated by `/`, a token does not start with a
digit, and a name does not end with `/` or contain `//`. A leading `~` (private)
is allowed. Whitelist patterns may also use `*`.

    topic status: carla_msgs/CarlaEgoVehicleStatus = "/carla/hero/vehicle_status" """,
    ),
    (
        "RMV205",
        "invalid ROS node name or pattern",
        """A node name or node pattern in a whitelist breaks the ROS naming rules. Node
names are like topic names; `*` matches any run of characters inside one
pattern, which serves anonymous nodes: "/rostopic_*".""",
    ),
    (
        "RMV206",
        "invalid ROS message type",
        """A message type must be `package/Type` (ROS 1) or `package/msg/Type` (ROS 2).
Package names are lower case (letters, digits, underscores, starting with a
letter); type names start with an upper-case letter.""",
    ),
    (
        "RMV207",
        "unknown setting",
        """A block has a setting it does not know. The allowed settings of each block
are listed in docs/language.md; the help line suggests the closest one.""",
    ),
    (
        "RMV208",
        "invalid setting value",
        """A setting has a value of the wrong form, for example a port that is not a
number in 1..65535, a precision that is not one of ns, u, ms, s, m, h, or a
QoS reliability that is not `reliable` or `best_effort`.""",
    ),
    (
        "RMV209",
        "missing required element",
        """A declaration lacks something it needs: a transducer without `states` or
without `initial`, a database without `name`, a retention policy without a
`duration`, a downsample without `into`.""",
    ),
    (
        "RMV210",
        "state of another transducer",
        """A transition, `initial` or `final` names a state that is not declared in the
`states` list of this transducer. Add it to `states`, or fix the name.""",
    ),
    (
        "RMV211",
        "credentials written in clear",
        """A password or token is written as a literal in the spec. Specs are shared and
versioned, so credentials are taken from the environment instead:

    password = env("RMV_INFLUX_PASSWORD")""",
    ),
    (
        "RMV212",
        "future operator without a time bound",
        """The operators that look ahead, `until`, `eventually` and `always`, need a
bound such as `[<10s]`, `[<=10s]` or `[=10s]`: without one a verdict could wait
for ever. The past operators `since`, `once` and `historically` may go without
one; they then read the whole trace so far, in constant memory.

    HardBraking -> eventually[<=10s] Stopped
    Stopped -> once Started""",
    ),
    (
        "RMV213",
        "time value without a unit",
        """A time bound or duration is a bare number and the spec declares no time unit.
Write the unit (`10s`, `100ms`), or declare one for the whole spec:

    time unit s""",
    ),
    (
        "RMV214",
        "declared more than once",
        """A declaration that may appear once per spec (`system`, `time unit`, an unnamed
`database`, a global `intrusion` block) or once per block (a `group by`, a `fill`)
appears twice. The secondary label shows the first one.""",
    ),
    (
        "RMV215",
        "unknown function",
        "An event expression calls a function that InfluxQL does not have. Supported:\n",
    ),
    (
        "RMV216",
        "unknown action",
        """An `action` names an unknown kind. Actions are `log(message, level = info)`,
`publish(topic, message)` on a ROS topic (std_msgs/String), `post(url)` (HTTP
POST of the alert as JSON), `exec(command, args...)` and `tcp(address)`.""",
    ),
    (
        "RMV217",
        "invalid action arguments",
        """An action has too few or too many arguments, an argument of the wrong form,
or an unknown keyword argument. See RMV216 for each action's arguments.""",
    ),
    (
        "RMV218",
        "invalid array aggregate",
        """A variable aggregates over an array (`max(objects.objects[*].twist.linear.x)`)
but its path has no `[*]`, or it names an aggregate the language does not have.
Array aggregates are `min`, `max`, `sum`, `mean`, `count`, `any`, `all`.""",
    ),
    (
        "RMV219",
        "time bound not positive",
        """A time bound, duration window, group-by interval or rate is zero or negative,
or shorter than a nanosecond. Bounds of temporal operators must be positive:
`until[<0s]` can never hold. Times are whole nanoseconds, as InfluxDB's: a window
of `0.5ns` would be 0 ns long, and no run could execute it.""",
    ),
    (
        "RMV220",
        "events defined in a cycle",
        """An event uses itself, directly or through other events:

    event A = mean(B) * 2
    event B = mean(A) + 1     // error: A -> B -> A

Each event is computed from variables and events computed before it, so the
definitions must form no cycle. A transducer counts: it reads the events of its
transitions, and an event reading what it emits reads it.

    event Echo when Moving or Bounced
    transducer Bouncer {
        states Up, Down
        initial Up
        Up -> Down on Echo emit Bounced   // error: Echo -> Bouncer -> Echo
    }""",
    ),
    (
        "RMV221",
        "a keyword as a name",
        """A declaration is named with a word that expressions or formulas reserve
(`and`, `or`, `not`, `true`, `false`, `until`, `since`, `eventually`, `always`,
`once`, `historically`, `duration`): every use of the name would be read as the
keyword, so nothing could refer to it. Rename it.

    event always when Velocity > 1     // RMV221
    event Always when Velocity > 1     // ok: names are case-sensitive""",
    ),
    (
        "RMV222",
        "the whitelists disagree",
        """(warning) A node's declaration and a topic's whitelist disagree about an
endpoint the spec itself describes: the node is declared to publish (or subscribe
to) a topic whose whitelist does not allow it, or a topic's whitelist allows a node
whose declaration does not list the topic. When the system runs as declared, the
monitor reports an intrusion. Add the name where it is missing (an editor offers
the edit), or remove it where it is wrong.

    whitelist "/cmd" { publishers: "/planner" }
    node "/teleop" { publishes: "/cmd" }        // RMV222: /cmd does not allow /teleop

Only exact names are compared: a pattern on both sides may or may not overlap.""",
    ),
    (
        "RMV223",
        "costly window",
        """(warning) A `group by time(...)` window or a `resample every` shorter than 1ms.
The runtime computes a continuous query the way InfluxDB does: one run per `every`,
one window per interval, whether or not a message falls in it. A window of 1us is
1,000,000 runs per second of input: a one-hour recording takes 3.6 billion. Use a
window of 1ms or more, or, to see every message, an event without a window.""",
    ),
    (
        "RMV224",
        "stamped topics with no lateness",
        """(warning) A property reads two or more topics whose time is their
`header.stamp` (`time = header`) and has no `lateness`. Messages of two publishers
do not arrive in the order of their stamps: one stamped before a message already
read is late, and dropped (counted, reported, never used; the verdicts that would have read
it are `unknown`, docs/runtime.md "Late input"). With `time = header` on
two topics at 10x playback, 3 of 600 messages were dropped as 0.05 s late. Give the
property the most the two topics' stamps can disagree on arrival:

    property P: ... { lateness = 100ms }

The monitor then holds input that long and puts it in order.""",
    ),
    (
        "RMV225",
        "ROS's own topics in the whitelists",
        """(warning) What ROS itself has every node do, against a whitelist that says
otherwise. With `infrastructure = ros` (the default), every node may publish
`/rosout` (and, on ROS 2, `/parameter_events`) and subscribe to `/clock` (and
`/parameter_events`) — unless a whitelist names the topic: then its lists decide,
and every node they leave out is reported, though every node uses the topic.

    whitelist "/rosout" { publishers: "/logger" }   // RMV225: every node publishes /rosout

With `infrastructure = none`, a node declaration that lists what the node
publishes or subscribes to but leaves out ROS's own topics is reported for them as
soon as the node runs (an editor offers the edit that adds them).""",
    ),
    (
        "RMV226",
        "the spec checks nothing",
        """(warning) The spec declares no property, no alert, no whitelist and no node
rule (and no `intrusion` block): whatever a recording or a running system does,
its replay passes and its monitor stays silent. An empty file, or a file of
topics and variables meant to be imported, says this when checked on its own.
Add what must hold:

    property NeverStops: not Stopped
    whitelist status { publishers: "/carla_bridge" }

`rmv replay` of such a spec exits 2 rather than pass.""",
    ),
    (
        "RMV300",
        "unknown message type",
        """A topic's message type is not among the definitions rmvdsl knows: the
standard packages of the target ROS distribution (from the `rosbags` package) and
the .msg files on the search path. The help line names the closest known type.

Custom messages: put their folder on the path, in the spec or on the command line:

    messages "msg"                  // <pkg>/msg/*.msg below ./msg
    rmv check --messages ~/ws/src spec.rmv

A sourced ROS workspace (AMENT_PREFIX_PATH, CMAKE_PREFIX_PATH, ROS_PACKAGE_PATH) is
searched too.""",
    ),
    (
        "RMV301",
        "no such field",
        """A variable's path names a field its message does not have. The error points
at that segment, with the closest real field. ROS 1 and ROS 2 differ here: ROS 1
time has `secs`/`nsecs` and its Header a `seq`; ROS 2 time has `sec`/`nanosec` and
no `seq`. Choose the distribution with `ros noetic` (or humble, jazzy, ...).""",
    ),
    (
        "RMV302",
        "wrong indexing",
        """An array field must say which element: `objects[0]`, or `objects[*]` for every
element (then aggregate: `max(objects.objects[*].twist.linear.x)`). A field that is
not an array cannot be indexed, and a fixed-size array has indices 0..N-1.""",
    ),
    (
        "RMV303",
        "a whole message is not a value",
        """A variable must end at a value (a number, bool, string or time), not at a
message. Pick one of the message's fields: `odometry.pose.pose.position.x`, not
`odometry.pose`.""",
    ),
    (
        "RMV304",
        "message definition does not parse",
        """A .msg file on the search path has a line rmvdsl cannot read. Each line is
`TYPE NAME`, `TYPE NAME DEFAULT` or `TYPE NAME=VALUE` (a constant), where TYPE is a
primitive (`bool`, `int8`..`uint64`, `float32`, `float64`, `string`, `time`,
`duration`), a message (`Point`, `geometry_msgs/Point`) and may end in `[]`, `[N]`
or `[<=N]`; `#` starts a comment.""",
    ),
    (
        "RMV305",
        "unknown ROS distribution",
        """`ros` names a distribution rmvdsl has no message definitions for. Known: noetic
(and melodic, kinetic, read with noetic's definitions), dashing, eloquent, foxy,
galactic, humble, iron, jazzy, kilted. Without `ros`, rmvdsl uses jazzy.""",
    ),
    (
        "RMV306",
        "message folder not found",
        """A `messages "path"` declaration (or `--messages`) names a folder that does not
exist. Paths in a spec are relative to the spec's folder.""",
    ),
    (
        "RMV307",
        "invalid rmv.toml",
        """The rmv.toml beside the spec cannot be read. It may hold:

    ros = "humble"
    messages = ["msg", "../other_ws/src"]
    solver_timeout = 10     # seconds per solver call on the properties
    solver_effort = 500000  # z3's resource limit per call (the same on every machine)
    solver_jobs = 4         # processes answering solver questions at once (one a core)

(optionally under a `[rmv]` table); folders are relative to the file.""",
    ),
    (
        "RMV308",
        "unknown key in rmv.toml",
        """rmv.toml holds a key that rmv does not read: most often a misspelling, which
would otherwise be ignored without a word.

    solver_timout = 10    // RMV308: did you mean `solver_timeout`?

The keys are `ros`, `messages`, `solver_timeout`, `solver_effort` and
`solver_jobs`.""",
    ),
    (
        "RMV310",
        "operand of the wrong type",
        """An operator got an operand it cannot use: arithmetic on a string or a bool,
bitwise operators on a float, `-` on a string. A bool field becomes 0 or 1 only
where declared: `var HandBrakeOn = number(status.control.hand_brake)`.""",
    ),
    (
        "RMV311",
        "incomparable values",
        """The two sides of a comparison cannot be compared: a string with a number, a
bool with a number, or strings and bools with `<` or `>` (they have only `=` and
`!=`; strings also `=~` and `!~` against a regular expression).""",
    ),
    (
        "RMV312",
        "not a condition",
        """A boolean event's condition, a `where` clause, an alert level, a reset, and
the operands of `and`, `or` and `not` must be true or false. A number is not:
compare it (`BrakePedal > 0.8`).""",
    ),
    (
        "RMV313",
        "function argument of the wrong type",
        """A function got an argument it cannot use: `mean`, `derivative` and the other
numeric functions need numbers (`count`, `first`, `last`, `distinct`, `mode` take
anything); `top`, `bottom`, `moving_average` and `sample` need a positive whole
count as second argument; `any`/`all` need bools; `number(...)` one bool.""",
    ),
    (
        "RMV314",
        "wrong number of arguments",
        """A function is called with too few or too many arguments: `mean(x)`,
`derivative(x)` or `derivative(x, 1s)`, `moving_average(x, 5)`, `pow(x, 2)`.""",
    ),
    (
        "RMV315",
        "mixed time units",
        """Two values with different time units are compared or added: a derivative (a
value per second) with the value itself, or in a property a duration with a plain
number. Constants adapt; otherwise convert:

    event Braking when derivative(mean(Velocity), 1s) < -5      // ok: a constant
    event Wrong when derivative(mean(Velocity), 1s) < Velocity  // RMV315
    property P: duration[10s](A) < 4s                           // ok
    property Q: duration[10s](A) < 4                            // RMV315 without `time unit`""",
    ),
    (
        "RMV316",
        "a time was expected",
        """A place that takes a time got something else, for example the unit argument
of `derivative(x, 1s)`, or a rate (`10Hz`) where a period is needed.""",
    ),
    (
        "RMV317",
        "reset on another measurement",
        """An alert's reset condition must watch the measurement its condition watches
(Kapacitor resets the level that the same stream raised):

    warn when Speed > 70 reset when Speed < 60        // ok
    warn when Speed > 70 reset when Throttle < 0.1    // RMV317""",
    ),
    (
        "RMV318",
        "window shorter than the horizon",
        """A property's `window` (the history its monitor keeps; the thesis's
`monitor_range`) is shorter than its horizon: how far the formula looks ahead and
back. Formula 3.1 needs 10 time units, so the thesis's 4 s range cannot decide it:

    property ABSCheck: (H -> (A or H) until[<10s] S) and duration[10s](H) < 4s {
        window = 4s      // RMV318: the horizon is 10s
    }""",
    ),
    (
        "RMV319",
        "invalid regular expression",
        """The right side of `=~` or `!~` must be a regular expression written as a
string, and it must compile.""",
    ),
    (
        "RMV320",
        "array used as a value",
        """A variable ends at an array (or goes through `[*]`) without reducing it to one
value. Aggregate it, `var Fastest = max(objects.objects[*].twist.linear.x)`, or
pick an element, `objects.objects[0].twist.linear.x`.""",
    ),
    (
        "RMV321",
        "not a query InfluxDB runs",
        """A value event is an InfluxQL continuous query, and InfluxDB refuses these
shapes (so does the runtime, which computes events exactly as InfluxDB does):

    event A = mean(Velocity)                             // no window: add `group by time(1s)`
    event B = Velocity * 2 group by time(1s)             // a window but no aggregate
    event C = derivative(Velocity) group by time(1s)     // write derivative(mean(Velocity))
    event D = mean(Velocity) + Brake group by time(1s)   // Brake raw beside an aggregate
    event G = mean(Velocity) group by time(2s) resample for 1s   // a run reads < a window
    event E = mean(Velocity) * 3.6 group by time(1s)     // ok
    event F = derivative(Velocity, 1s)                   // ok: over the raw points

A condition (`event H when ...`, a `where` clause) reads the newest value of each
name: it may transform a value, `abs(Velocity) > 3`, but a transformation of a
series needs the points themselves:

    event H when derivative(Velocity) < -5               // declare the series first:
    event Slope = derivative(Velocity)                   // ok
    event H when Slope < -5                              // ok

InfluxDB's WHERE applies a function to a field or a constant only, and has no
`log` with a base:

    event J = max(Speed) where abs(Speed - 3) > 1 group by time(1s)  // matches no row
    event K = max(Speed) where abs(Speed) > 1 group by time(1s)      // ok
    event L = max(Speed) where log(Speed, 2) > 1 group by time(1s)   // refused
    event M = max(Speed) where ln(Speed) / ln(2) > 1 group by time(1s)  // ok""",
    ),
    (
        "RMV322",
        "no header stamp",
        """`time = header` in a topic's block stamps each message with its
`header.stamp`, so the message type must have a `header` field of type
std_msgs/Header. Use `time = receipt` (the default: the time the message arrives)
for a type without one:

    topic clock: std_msgs/Float64 = "/value" qos { time = header }   // RMV322
    topic odom: nav_msgs/Odometry = "/odom" qos { time = header }     // ok""",
    ),
    (
        "RMV500",
        "unreachable state",
        """No sequence of transitions leads from the transducer's initial state to this
state: the monitor can never be in it, and a property about it is vacuous. Add a
transition into it, or remove it.""",
    ),
    (
        "RMV501",
        "state with no way out",
        """(warning) No transition leaves this state, and it is not declared final: once
there, the transducer stays forever. If that is meant, say so: `final Stopped`.""",
    ),
    (
        "RMV502",
        "input that never holds",
        """(warning) A transition's input can never hold: a boolean event whose condition
is unsatisfiable (`Velocity > 5 and Velocity < 1`), or an event emitted only by
transitions out of unreachable states. The transition is never taken.""",
    ),
    (
        "RMV503",
        "output nothing uses",
        """(warning) A transition emits an event that no transition, property or alert
reads. Use it, or drop the `emit`.""",
    ),
    (
        "RMV504",
        "transducer nothing observes",
        """(warning) No property, alert or event mentions any state or output of this
transducer: it estimates states that nobody checks.""",
    ),
    (
        "RMV505",
        "non-deterministic transitions",
        """Two transitions leave the same state on inputs that can hold at the same time,
towards different states: which one the monitor takes is not defined. z3 decides
whether the two events' conditions can hold together and the message gives values
that make them (`BrakePedal = 0.9`). Make the conditions exclusive:

    event HardBrake when BrakePedal > 0.8
    event SoftBrake when BrakePedal > 0.3 and not HardBrake""",
    ),
    (
        "RMV506",
        "incomplete state",
        """(warning, only for transducers marked `complete`) In some state, for some
values of the variables no transition's input holds. The message gives such values.""",
    ),
    (
        "RMV510",
        "property that can never hold",
        """No trace makes the property true, at any time: its monitor reports a violation on
every run, whatever the system does. `eventually[<10s] p and always[<10s] not p` is
an example. The answer is exact: z3 refuted the formula over all functions of time,
not only over a bounded family of traces (docs/verification.md). Check the bounds
and the connectives; `rmv sat --formula '...'` answers the same question for a
piece of the formula.""",
    ),
    (
        "RMV511",
        "property impossible for this system",
        """The formula is satisfiable in pure logic (the note shows a trace), but not on
the traces this spec can produce: a transducer is in exactly one of its states at
a time, never in one its initial state cannot reach, and changes only along its
transitions; events whose conditions exclude each other never hold together. So
the monitor reports a violation on every run. Typical cause: a property that needs
two states of one transducer at once (`eventually[<5s] (Stopped and HardBraking)`),
or a move the transitions do not allow.""",
    ),
    (
        "RMV512",
        "property that can never fail",
        """(warning) The property holds on every trace (of this system, when its states
constrain it): its monitor can never fire, which gives false assurance. The answer
is exact: z3 refuted the negation. `p or not p` is the plain case;
`always[<10s] a -> a` another (what holds for 10 s holds now).""",
    ),
    (
        "RMV513",
        "vacuous implication",
        """(warning) In `A -> B`, A can never hold (at any time, on any trace of this
system), so the implication is true whatever B says: the part of the property it
was meant to check checks nothing. Check A's states, events and bounds.""",
    ),
    (
        "RMV514",
        "conflicting properties",
        """Each property can hold alone, but no trace makes all of them hold at one time:
on every run at least one of their monitors fires. The message names a smallest
conflicting subset (minimised in the properties' order: drop any member and the
rest can hold together), each member labelled in the source. Weaken one of them.""",
    ),
    (
        "RMV515",
        "redundant property",
        """(note) The property is implied by the ones named: whenever they hold, it
holds, so its monitor fires only when one of theirs does. Keep it if it carries
its own alert or actions; otherwise it can go. Checked within each group of
properties that share propositions (properties over other states and events
cannot imply it, unless they cannot hold at all), for groups of at most 24
properties (one solver question per property).""",
    ),
    (
        "RMV516",
        "property not decided",
        """(note) The solver's time limit was reached before it could decide whether the
property can hold (or fail). Nothing is claimed. Raise the limit with
`rmv check --timeout SECONDS` (default 5 s per solver call), or split the
property.""",
    ),
    (
        "RMV517",
        "redundancy not checked",
        """(note) The properties named share propositions, so each could imply another,
but they are more than 24: asking whether each is implied by the others would cost
one solver question per property over all the rest, and `rmv check` skips it
rather than take minutes. Nothing is claimed about their redundancy; the other
analyses (each property alone, conflicts between them) ran. Split the group (a
property over other states and events is in another group) to have it checked.""",
    ),
    (
        "RMV600",
        "the target cannot build the spec",
        """Only with `rmv check --target NAME`: the spec checks clean, but the target of
`rmv build` named cannot build it, and says why at the declaration it needs or
cannot express. The kapacitor target stores the variables in InfluxDB, so it needs
a `database` block:

    database { name = "robot" }

`rmv build --target NAME` on the same spec stops with the same reason (exit 2).""",
    ),
    (
        "RMV601",
        "the target leaves a part out",
        """(note) Only with `rmv check --target NAME`: a part of the spec that the named
target does not compute, at its declaration, and which target does. The kapacitor
target writes continuous queries for windowed events and TICKscripts for alerts;
boolean events, transducers, RMTLD3 properties and whitelists are computed by the
monitor and intrusion nodes of the ros2 and ros1 targets, and `rmv build --target kapacitor` lists
the same parts in its README.md.""",
    ),
]

CODES: dict[str, Code] = {code: Code(code, title, text) for code, title, text in _TABLE}
# Explanations ending with what the registries say, worked out when first read.
_ADDED: dict[str, Callable[[], str]] = {"RMV215": _function_list}


def explain(code: str) -> str | None:
    entry = CODES.get(code.upper())
    if entry is None:
        return None
    return f"{entry.code}: {entry.title}\n\n{entry.explanation}\n"


def diagnostics_markdown() -> str:
    """The text of docs/diagnostics.md."""
    parts = [
        "# Diagnostics\n",
        "Every diagnostic of `rmv check` has a stable code. `rmv explain CODE` prints the",
        "same text as this page. This page is generated from `rmvdsl/lang/codes.py`",
        "(`python -m rmvdsl.lang.codes > docs/diagnostics.md`).\n",
        "Ranges: RMV0xx files and imports, RMV1xx syntax, RMV2xx names and structure,",
        "RMV3xx types, RMV5xx analyses.\n",
    ]
    for entry in CODES.values():
        parts.append(f"## {entry.code}: {entry.title}\n")
        parts.append("```text")
        parts.append(entry.explanation)
        parts.append("```\n")
    return "\n".join(parts)


if __name__ == "__main__":
    print(diagnostics_markdown(), end="")
