#!/bin/bash
# PREREGISTRATION.md's runs: run.sh's registered stage.
exec bash "$(dirname "$0")/run.sh" registered
