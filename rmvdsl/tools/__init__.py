"""Tools over a checked spec: `rmv replay` over recordings and its report, and
`rmv graph`'s transducer diagrams."""
