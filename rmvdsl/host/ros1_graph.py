"""The ROS 1 graph as the intrusion node reads it, over XML-RPC (standard library
only): the master's `getSystemState` (who registered what), `lookupNode` (each
node's XML-RPC address), and every node's own `getBusInfo` (its live
connections).

The master alone misses two things. A node killed with SIGKILL stays registered
for ever, as if it were alive: a node whose XML-RPC server does not answer is
`stale`. And a peer can skip the master: advertise, unregister, then call
`publisherUpdate` on a subscriber, which connects to it and reads its messages
though no registration says so. The subscriber's bus info shows that connection,
to an address no registered publisher of the topic has; a publisher's bus info
likewise shows a subscriber connected under a name the master does not list for
the topic.
"""

from __future__ import annotations

import dataclasses
import http.client
import xmlrpc.client
from collections.abc import Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlsplit

from rmvdsl.host.intrusion import GONE, SLOW, Seen

# Seconds an XML-RPC call may take before its node counts as not answering.
TIMEOUT = 1.0


class MasterError(Exception):
    """The master cannot be reached or refused a call; the text says which."""


@dataclass
class Graph:
    """One reading: endpoints the master registered, connections it did not,
    and the registered nodes that did not answer this time, and how (GONE: the
    call was refused; SLOW: it timed out)."""

    registered: list[Seen] = field(default_factory=list)
    unregistered: list[Seen] = field(default_factory=list)
    silent: dict[str, str] = field(default_factory=dict)
    # What the master listed, as a connection names it: (topic, "publisher", the
    # publisher's address) and (topic, "subscriber", the subscriber's name); each
    # with the node's name.
    listed: dict[tuple[str, str, str], str] = field(default_factory=dict)


class Reader:
    """The graph, poll after poll. A connection of an endpoint the master listed in
    an earlier poll and no longer lists is that endpoint still, judged by its name,
    while the connection lasts: a node leaving, a subscriber retrying a publisher
    that stopped, a publisher that never writes again and so never notices that its
    subscriber left. None of them skipped the master; an endpoint the spec refused
    stays refused until its last connection ends."""

    def __init__(self, master_uri: str, caller: str, timeout: float = TIMEOUT) -> None:
        self.master_uri, self.caller, self.timeout = master_uri, caller, timeout
        # listed now, or departed and still connected: key -> the node's name
        self.listed: dict[tuple[str, str, str], str] = {}

    def read(self) -> Graph:
        graph = read(self.master_uri, self.caller, self.timeout)
        departed, unregistered = {}, []
        for seen in graph.unregistered:
            node = self.listed.get(key := _key(seen))
            if node is None:
                unregistered.append(seen)
                continue
            departed[key] = node
            graph.registered.append(Seen(seen.topic, seen.role, *split_name(node), node.encode()))
        graph.unregistered = unregistered
        self.listed = {**graph.listed, **departed}
        return graph


def _key(seen: Seen) -> tuple[str, str, str]:
    return seen.topic, seen.role, seen.node_name


class _Transport(xmlrpc.client.Transport):
    """XML-RPC over HTTP with a timeout: a stopped node must not stop the poll."""

    def __init__(self, timeout: float) -> None:
        super().__init__()
        self.timeout = timeout

    def make_connection(self, host: Any) -> http.client.HTTPConnection:
        connection = super().make_connection(host)
        connection.timeout = self.timeout
        return connection


def proxy(uri: str, timeout: float = TIMEOUT) -> xmlrpc.client.ServerProxy:
    return xmlrpc.client.ServerProxy(uri, transport=_Transport(timeout), allow_none=True)


def address(uri: str) -> str:
    """`host:port` of an XML-RPC URI (how an unregistered peer is named)."""
    parts = urlsplit(uri)
    return f"{parts.hostname}:{parts.port}" if parts.hostname else uri


def split_name(node: str) -> tuple[str, str]:
    """A node's full name as (namespace, name), the way Seen holds it."""
    namespace, _, name = node.rpartition("/")
    return namespace or "/", name


def _call(function: Any, *args: Any) -> Any:
    code, text, value = function(*args)
    if code != 1:
        raise MasterError(text)
    return value


def read(master_uri: str, caller: str, timeout: float = TIMEOUT) -> Graph:
    """Read the graph once: the master, then every registered node."""
    master = proxy(master_uri, timeout)
    try:
        publishers, subscribers, _services = _call(master.getSystemState, caller)
    except (OSError, xmlrpc.client.Error, MasterError, ValueError) as error:
        raise MasterError(f"the ROS master at {master_uri} did not answer: {error}") from None
    registered: dict[tuple[str, str], set[str]] = {}  # (topic, role) -> nodes
    for role, table in (("publisher", publishers), ("subscriber", subscribers)):
        for topic, nodes in table:
            registered.setdefault((topic, role), set()).update(nodes)
    nodes = sorted({n for names in registered.values() for n in names})
    uris, unknown = _lookup(master, caller, nodes)
    buses = _bus_info(caller, uris, timeout)
    silent = {n: how for n, how in buses.items() if isinstance(how, str)}
    graph = Graph(silent={**unknown, **silent})
    for (topic, role), names in sorted(registered.items()):
        for node in sorted(names):
            graph.registered.append(Seen(topic, role, *split_name(node), node.encode()))
            named = address(uris[node]) if role == "publisher" and node in uris else node
            graph.listed[(topic, role, named)] = node
    graph.unregistered = _answering(caller, _unregistered(registered, uris, buses), timeout)
    return graph


def _lookup(
    master: Any, caller: str, nodes: Iterable[str]
) -> tuple[dict[str, str], dict[str, str]]:
    """Each node's XML-RPC URI; and the nodes the master did not look up in time,
    as SLOW: whether they answer is not known this poll, and a busy master must not
    make a live node look gone (CI saw an allowed node called stale). A node the
    master forgot meanwhile (it unregistered) is in neither."""
    found, unknown = {}, {}
    for node in nodes:
        try:
            found[node] = _call(master.lookupNode, caller, node)
        except TimeoutError:
            unknown[node] = SLOW
        except (OSError, xmlrpc.client.Error, MasterError, ValueError):
            continue
    return found, unknown


def _bus_info(caller: str, uris: dict[str, str], timeout: float) -> dict[str, list[Any] | str]:
    """Each node's connections, asked of all at once; or how it did not answer:
    SLOW (no answer in `timeout`: busy or hung), GONE (anything else: refused)."""

    def ask(uri: str) -> list[Any] | str:
        try:
            return list(_call(proxy(uri, timeout).getBusInfo, caller))
        except TimeoutError:
            return SLOW
        except (OSError, xmlrpc.client.Error, MasterError, ValueError):
            return GONE

    if not uris:
        return {}
    with ThreadPoolExecutor(max_workers=min(16, len(uris))) as pool:
        answers = pool.map(ask, uris.values())
        return dict(zip(uris, answers, strict=True))


def _unregistered(
    registered: dict[tuple[str, str], set[str]],
    uris: dict[str, str],
    buses: dict[str, list[Any] | str],
) -> list[Seen]:
    """Connections no registration accounts for. A subscriber's inbound
    connection names the publisher's XML-RPC URI; a publisher's outbound one, the
    name the subscriber gave."""
    publishers = {  # topic -> the addresses of its registered publishers
        topic: {address(uris[n]) for n in nodes if n in uris}
        for (topic, role), nodes in registered.items() if role == "publisher"
    }  # fmt: skip
    found: dict[tuple[str, str, str], Seen] = {}
    for connections in buses.values():
        for connection in connections if isinstance(connections, list) else ():
            if len(connection) < 5:
                continue
            peer, direction, topic = str(connection[1]), connection[2], str(connection[4])
            if direction == "i":
                if address(peer) in publishers.get(topic, set()):
                    continue
                name, role = peer, "publisher"  # its XML-RPC URI, named by its address
            elif direction == "o":
                if peer in registered.get((topic, "subscriber"), set()):
                    continue
                name, role = peer, "subscriber"
            else:
                continue
            found[(topic, role, name)] = Seen(topic, role, "", name, name.encode(), False)
    return [found[key] for key in sorted(found)]


def _answering(caller: str, seen: list[Seen], timeout: float) -> list[Seen]:
    """The unregistered peers, each publisher's (named by its XML-RPC URI) asked
    whether it is still there and named by its address: a stopped node's
    connection, which its subscriber retries for a while, is told from a live
    peer that skipped the master."""
    uris = sorted({s.node_name for s in seen if s.role == "publisher"})

    def answers(uri: str) -> bool:
        try:
            _call(proxy(uri, timeout).getPid, caller)
            return True
        except (OSError, xmlrpc.client.Error, MasterError, ValueError):
            return False

    live = {}
    if uris:
        with ThreadPoolExecutor(max_workers=min(16, len(uris))) as pool:
            live = dict(zip(uris, pool.map(answers, uris), strict=True))
    found = []
    for endpoint in seen:
        if endpoint.role == "publisher":
            name = address(endpoint.node_name)
            endpoint = dataclasses.replace(endpoint, node_name=name, gid=name.encode(),
                                           answering=live[endpoint.node_name])  # fmt: skip
        found.append(endpoint)
    return found
