"""The languages rmvdsl writes and reads besides its own: InfluxQL and TICKscript,
each one module with a small syntax tree, the one quoting rule, a printer and a
parser (standard library only; targets print through them, importers and
`rmv deploy` parse through them)."""
