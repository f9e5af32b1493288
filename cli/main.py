"""The `pyspatial` command: serve, solve, route, reconstruct, render, demo, synth, eval, bench and weights."""

from __future__ import annotations

import typer

from cli.bench import bench
from cli.demo import demo
from cli.eval_commands import eval_app
from cli.reconstruct import reconstruct
from cli.render import render
from cli.route import route
from cli.serve import serve
from cli.solve import solve
from cli.synth import synth
from cli.weights import weights_app

app = typer.Typer(
    name="pyspatial",
    help="Answer spatial questions about a few photos: reconstruct, write a program, run it, answer.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)
app.command()(serve)
app.command()(solve)
app.command()(reconstruct)
app.command()(render)
app.command()(route)
app.command()(demo)
app.command()(synth)
app.add_typer(eval_app, name="eval")
app.add_typer(weights_app, name="weights")
app.command(
    short_help="Run a benchmark from bench/ (pyspatial bench --help lists them).",
    context_settings={"allow_extra_args": True, "ignore_unknown_options": True},
)(bench)


if __name__ == "__main__":
    app()
